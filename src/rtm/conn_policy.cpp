// SPDX-License-Identifier: Apache-2.0
#include "rtm/conn_policy.h"

#include "rtm/describe.h"

#include <charconv>
#include <limits>
#include <stdexcept>
#include <vector>

namespace rtm {

namespace {

constexpr const char* kKeys = "once, repeated, reader=, depth=, delivery=, call=, path=";

[[noreturn]] void bad(std::string_view token, const std::string& why) {
  throw std::invalid_argument("connection policy: '" + std::string(token) + "': " + why);
}

std::uint32_t parse_count(std::string_view token, std::string_view digits, std::uint32_t max) {
  std::uint64_t value = 0;
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  if (digits.empty() || ec != std::errc{} || end != digits.data() + digits.size() || value > max)
    bad(token, "a whole number from 0 to " + std::to_string(max) + " is expected");
  return static_cast<std::uint32_t>(value);
}

ReaderPolicy parse_reader(std::string_view token, std::string_view text) {
  ReaderPolicy r;
  if (text == "latest") {
    r.kind = ReaderPolicy::Kind::latest;
  } else if (text == "callback") {
    r.kind = ReaderPolicy::Kind::callback;
  } else if (text == "fifo") {
    r.kind = ReaderPolicy::Kind::fifo;
  } else if (text.starts_with("fifo:")) {
    r.kind = ReaderPolicy::Kind::fifo;
    r.capacity = parse_count(token, text.substr(5), 1'000'000);
    if (r.capacity == 0) bad(token, "a FIFO holds at least 1 datum");
  } else {
    bad(token, "the reader is latest, fifo, fifo:<capacity> or callback");
  }
  return r;
}

}  // namespace

const char* to_string(ConnKind kind) {
  switch (kind) {
    case ConnKind::in_process: return "in-process";
    case ConnKind::shared_memory: return "shared memory";
    case ConnKind::remote_by_writer: return "CORBA by writer";
    case ConnKind::remote_by_thread: return "CORBA by thread";
  }
  return "?";
}

std::string to_string(const ReaderPolicy& reader) {
  switch (reader.kind) {
    case ReaderPolicy::Kind::any: return "any";
    case ReaderPolicy::Kind::latest: return "latest";
    case ReaderPolicy::Kind::callback: return "callback";
    case ReaderPolicy::Kind::fifo: return reader.capacity ? "fifo:" + std::to_string(reader.capacity) : "fifo";
  }
  return "?";
}

bool satisfies(const ReaderPolicy& kept, const ReaderPolicy& wanted) {
  if (wanted.kind == ReaderPolicy::Kind::any) return true;
  if (kept.kind != wanted.kind) return false;
  return wanted.capacity == 0 || kept.capacity == wanted.capacity;
}

std::string to_string(const ConnPolicy& p) {
  std::string out = p.once ? "once" : "repeated";
  if (p.reader.kind != ReaderPolicy::Kind::any) out += " reader=" + to_string(p.reader);
  if (p.depth != 0) out += " depth=" + std::to_string(p.depth);
  if (p.delivery == ConnPolicy::Delivery::writer_when_idle) out += " delivery=writer";
  if (p.delivery == ConnPolicy::Delivery::thread) out += " delivery=thread";
  if (p.call_timeout_ms != 0) out += " call=" + std::to_string(p.call_timeout_ms) + "ms";
  if (p.corba_only) out += " path=corba";
  return out;
}

ConnPolicy parse_conn_policy(std::string_view text, std::optional<bool> once_apart) {
  ConnPolicy p;
  bool names_lifetime = false;
  std::vector<std::string_view> seen;  // keys given, to refuse one given twice
  const std::vector<std::string> words = split_words(text);
  for (const std::string_view token : words) {
    const std::size_t eq = token.find('=');
    const std::string_view key = token.substr(0, eq);
    const std::string_view value = eq == std::string_view::npos ? std::string_view{} : token.substr(eq + 1);
    const bool lifetime = key == "once" || key == "repeated";
    const std::string_view slot = lifetime ? std::string_view("once|repeated") : key;
    for (const auto& s : seen)
      if (s == slot) bad(token, "given twice");
    seen.push_back(slot);
    if (lifetime) {
      if (eq != std::string_view::npos) bad(token, "once and repeated take no value");
      p.once = key == "once";
      names_lifetime = true;
    } else if (eq == std::string_view::npos) {
      bad(token, std::string("not a policy; one of ") + kKeys + " is expected");
    } else if (key == "reader") {
      p.reader = parse_reader(token, value);
    } else if (key == "depth") {
      p.depth = parse_count(token, value, ConnPolicy::kMaxDepth);
    } else if (key == "delivery") {
      if (value == "writer") p.delivery = ConnPolicy::Delivery::writer_when_idle;
      else if (value == "thread") p.delivery = ConnPolicy::Delivery::thread;
      else bad(token, "delivery is writer or thread");
    } else if (key == "call") {
      if (!value.ends_with("ms")) bad(token, "a call bound is written in ms, e.g. call=1000ms");
      p.call_timeout_ms = parse_count(token, value.substr(0, value.size() - 2), 3'600'000);
    } else if (key == "path") {
      if (value == "corba") p.corba_only = true;
      else if (value != "auto") bad(token, "path is auto or corba");
    } else {
      bad(token, std::string("unknown key; one of ") + kKeys + " is expected");
    }
  }
  if (once_apart) {
    if (names_lifetime && p.once != *once_apart)
      throw std::invalid_argument("connection policy '" + std::string(text) + "' and " +
                                  (*once_apart ? "once" : "repeated") + " given beside it disagree");
    p.once = *once_apart;
  }
  return p;
}

ReaderPolicy parse_reader_policy(std::string_view text) { return parse_reader(text, text); }

RTM::ConnPolicy to_idl(const ConnPolicy& p) {
  RTM::ConnPolicy out{};
  out.req_type = p.once ? RTM::once : RTM::repeated;
  switch (p.reader.kind) {
    case ReaderPolicy::Kind::any: out.reader = RTM::READER_ANY; break;
    case ReaderPolicy::Kind::latest: out.reader = RTM::READER_LATEST; break;
    case ReaderPolicy::Kind::fifo: out.reader = RTM::READER_FIFO; break;
    case ReaderPolicy::Kind::callback: out.reader = RTM::READER_CALLBACK; break;
  }
  out.reader_capacity = p.reader.capacity;
  out.depth = p.depth;
  out.delivery = p.delivery == ConnPolicy::Delivery::writer_when_idle ? RTM::DELIVERY_BY_WRITER
                 : p.delivery == ConnPolicy::Delivery::thread       ? RTM::DELIVERY_BY_THREAD
                                                                    : RTM::DELIVERY_PORT_DEFAULT;
  out.call_timeout_ms = p.call_timeout_ms;
  out.corba_only = p.corba_only;
  return out;
}

ConnPolicy from_idl(const RTM::ConnPolicy& in) {
  ConnPolicy p;
  if (in.req_type != RTM::once && in.req_type != RTM::repeated)
    throw std::invalid_argument("connection policy: req_type out of range");
  p.once = in.req_type == RTM::once;
  switch (in.reader) {
    case RTM::READER_ANY: p.reader.kind = ReaderPolicy::Kind::any; break;
    case RTM::READER_LATEST: p.reader.kind = ReaderPolicy::Kind::latest; break;
    case RTM::READER_FIFO: p.reader.kind = ReaderPolicy::Kind::fifo; break;
    case RTM::READER_CALLBACK: p.reader.kind = ReaderPolicy::Kind::callback; break;
    default: throw std::invalid_argument("connection policy: reader out of range");
  }
  p.reader.capacity = p.reader.kind == ReaderPolicy::Kind::fifo ? in.reader_capacity : 0;
  if (in.depth > ConnPolicy::kMaxDepth) throw std::invalid_argument("connection policy: depth above " + std::to_string(ConnPolicy::kMaxDepth));
  p.depth = in.depth;
  switch (in.delivery) {
    case RTM::DELIVERY_PORT_DEFAULT: p.delivery = ConnPolicy::Delivery::port_default; break;
    case RTM::DELIVERY_BY_WRITER: p.delivery = ConnPolicy::Delivery::writer_when_idle; break;
    case RTM::DELIVERY_BY_THREAD: p.delivery = ConnPolicy::Delivery::thread; break;
    default: throw std::invalid_argument("connection policy: delivery out of range");
  }
  p.call_timeout_ms = in.call_timeout_ms;
  p.corba_only = in.corba_only;
  return p;
}

}  // namespace rtm
