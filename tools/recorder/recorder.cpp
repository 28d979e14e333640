// SPDX-License-Identifier: Apache-2.0
#include "recorder/recorder.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <memory>

#include "browser/json.h"
#include "browser/watch_port.h"
#include "browser/values.h"
#include "launcher/running_system.h"
#include "mcap/writer.h"
#include "rt/clock.h"
#include "rtm/cdr.h"
#include "rtm/data.h"
#include "stamp.h"

namespace rtm::cli {

namespace {

using Clock = std::chrono::steady_clock;

// Each subscriber holds this many data between two drains: at 500 Hz, seconds of a stalled
// disk before anything is lost (and then counted).
constexpr std::size_t kQueueCapacity = 8192;

std::string joined(const std::vector<std::string>& words) {
  std::string out;
  for (const auto& w : words) out += (out.empty() ? "" : ",") + w;
  return out;
}

std::vector<ResolvedPort> ports_to_record(const Browser& browser, const RecordOptions& options) {
  std::vector<std::string> addresses = options.ports;
  if (options.all) {
    for (const auto& c : browser.list("", Browser::Detail::brief)) {
      if (c.liveness != Liveness::alive) continue;
      for (const auto& p : c.ports)
        if (p.direction == Direction::out) addresses.push_back(c.path.name + "." + p.name);
    }
  }
  std::vector<ResolvedPort> ports;
  for (const auto& address : addresses) {
    auto port = browser.port(PortAddress::parse(address));
    if (port.direction != Direction::out) {
      throw BrowseError(fmt::format("{} is an InPort; record an OutPort", port.address));
    }
    const bool twice = std::any_of(ports.begin(), ports.end(), [&](const auto& p) { return p.address == port.address; });
    if (!twice) ports.push_back(std::move(port));
  }
  if (ports.empty()) throw std::invalid_argument("no port to record (name OutPorts, or --all)");
  return ports;
}

// One recorded port: its channel and its subscription.
struct Channel {
  ResolvedPort port;
  std::uint16_t id = 0;
  bool stamped = false;
  std::uint32_t sequence = 0;
  std::unique_ptr<WatchSubscription> subscription;
};

// Every type's IDL first: a type that cannot be written stops the recording before the file.
std::map<std::string, std::string> idl_of_each_type(const std::vector<Channel>& channels) {
  std::map<std::string, std::string> idl;  // type name -> IDL text
  for (const auto& c : channels) {
    try {
      idl.emplace(rtm::type_name(c.port.type), rtm::idl_text(c.port.type));
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(fmt::format("cannot record {}: {}", c.port.address, e.what()));
    }
  }
  return idl;
}

// The running system as a system file, and the components it could not hold.
void write_system(mcap::Writer& writer, const Browser& browser, RecordResult& result) {
  std::vector<LeftOut> left_out;
  const SystemFile system = running_system(browser, "recorded", left_out);
  mcap::KeyValues values{{"yaml", system.to_yaml()}};
  for (const auto& l : left_out) {
    result.left_out.push_back(fmt::format("{}: {}", l.name, l.why));
    values["left_out." + l.name] = l.why;
  }
  writer.add_metadata("rtm.system", values);
}

// The running system's timing (docs/timing.md): each component's contract and how it has kept
// it so far, one JSON value per component, as `rtm ls -l --json` gives its "contract". Written at
// the start (name "rtm.timing") and again at the end ("rtm.timing.end"): the run's own part is
// the difference. A component that cannot be asked is left out.
void write_timing(mcap::Writer& writer, const Browser& browser, const std::string& name) {
  mcap::KeyValues values;
  for (const auto& c : browser.list("", Browser::Detail::wiring)) {
    if (c.contract) values[c.path.name] = contract_json(*c.contract).dump();
  }
  writer.add_metadata(name, values);
}

void add_channels(mcap::Writer& writer, std::vector<Channel>& channels,
                  const std::map<std::string, std::string>& idl) {
  std::map<std::string, std::uint16_t> schema_ids;
  for (const auto& [name, text] : idl) schema_ids[name] = writer.add_schema(name, "omgidl", text);
  for (auto& c : channels) {
    const auto type = rtm::type_name(c.port.type);
    c.stamped = is_timed_type(c.port.type);
    const auto dot = c.port.address.find('.');
    c.id = writer.add_channel(schema_ids.at(type), c.port.address, "cdr",
                              {{"type", type},
                               {"component", c.port.address.substr(0, dot)},
                               {"port", c.port.name},
                               {"elements", joined(c.port.names())},
                               {"units", joined(c.port.units())},
                               {"log_time", c.stamped ? "the datum's stamp (tm)" : "its arrival at the recorder"},
                               {"typecode", rtm::type_code_text(c.port.type)}});
  }
}

// Takes what each subscription holds into the file until stopped or a limit is reached.
void record_until(mcap::Writer& writer, std::vector<Channel>& channels, const RecordOptions& options,
                  const std::function<bool()>& stop) {
  const auto start = Clock::now();
  auto last_flush = start;
  std::uint64_t total = 0;
  std::vector<CORBA::Any> batch;
  std::vector<std::uint8_t> cdr;
  // Each port is waited on in turn, for a share of a short round: data wait in each
  // subscriber's queue or ring meanwhile, never in the publisher.
  const auto share = std::max(std::chrono::milliseconds(1),
                              std::chrono::milliseconds(20) / static_cast<long>(channels.size()));
  const auto full = [&] { return options.count > 0 && total >= static_cast<std::uint64_t>(options.count); };
  const auto done = [&] {
    return full() ||
           (options.duration_s > 0 && Clock::now() - start >= std::chrono::duration<double>(options.duration_s));
  };
  while (!stop() && !done()) {
    for (auto& c : channels) {
      batch.clear();
      c.subscription->port().drain(batch, share);
      const auto arrived = static_cast<std::uint64_t>(rtm::realtime_ns());
      for (const auto& any : batch) {
        if (full()) break;
        rtm::to_cdr(any, cdr);
        writer.write(c.id, c.sequence++, c.stamped ? stamp_of(cdr) : arrived, arrived, cdr);
        ++total;
      }
    }
    if (Clock::now() - last_flush >= options.flush_every) {
      writer.flush();
      last_flush = Clock::now();
    }
  }
}

// What each port gave and lost, into the result and the file's "rtm.drops"; the subscriptions
// end.
void count_and_unsubscribe(mcap::Writer& writer, std::vector<Channel>& channels, RecordResult& result,
                           const std::function<void(const std::string&)>& progress) {
  mcap::KeyValues drops;
  for (auto& c : channels) {
    RecordedPort r;
    r.address = c.port.address;
    r.type = rtm::type_name(c.port.type);
    r.path = c.subscription->port().reads_ring() ? "shared memory" : "CORBA";
    r.recorded = c.sequence;
    r.dropped_by_publisher = c.subscription->publisher_dropped().value_or(0);
    r.dropped_by_recorder = c.subscription->port().overflowed();
    r.late = c.subscription->port().late();
    r.wrong_type = c.subscription->port().rejected();
    const auto failed = c.subscription->finish();
    if (!failed.empty()) progress(fmt::format("unsubscribing from {} failed: {}", r.address, failed));
    drops[r.address + ".recorded"] = std::to_string(r.recorded);
    drops[r.address + ".dropped_by_publisher"] = std::to_string(r.dropped_by_publisher);
    drops[r.address + ".dropped_by_recorder"] = std::to_string(r.dropped_by_recorder);
    drops[r.address + ".late"] = std::to_string(r.late);
    drops[r.address + ".wrong_type"] = std::to_string(r.wrong_type);
    result.ports.push_back(std::move(r));
  }
  drops["seconds"] = fmt::format("{:.3f}", result.seconds);
  writer.add_metadata("rtm.drops", drops);
}

}  // namespace

RecordResult record(const Browser& browser, rtm::Orb& orb, const RecordOptions& options,
                    const std::function<bool()>& stop, const std::function<void(const std::string&)>& progress) {
  if (options.output.empty()) throw std::invalid_argument("no output file (-o FILE.mcap)");
  if (!options.overwrite && std::filesystem::exists(options.output)) {
    throw std::invalid_argument(fmt::format("{} exists (--force to overwrite it)", options.output));
  }
  std::vector<Channel> channels;
  for (auto& port : ports_to_record(browser, options)) {
    auto& c = channels.emplace_back();
    c.port = std::move(port);
  }
  const auto idl = idl_of_each_type(channels);

  mcap::WriterOptions writer_options;
  writer_options.compression = options.compression;
  writer_options.library = "rtm record";
  writer_options.replace = options.overwrite;  // else one made since the check above is not lost either
  mcap::Writer writer(options.output, writer_options);
  RecordResult result;
  write_system(writer, browser, result);
  write_timing(writer, browser, "rtm.timing");
  add_channels(writer, channels, idl);
  const auto owner = fmt::format("rtm-record-{}", ::getpid());
  for (std::size_t i = 0; i < channels.size(); ++i) {
    auto& c = channels[i];
    c.subscription = std::make_unique<WatchSubscription>(orb, c.port.object, c.port.type, c.port.address,
                                                         fmt::format("{}-{}", owner, i), kQueueCapacity, "the recording");
    progress(fmt::format("recording {} ({})", c.port.address, rtm::type_name(c.port.type)));
  }

  const auto start = Clock::now();
  record_until(writer, channels, options, stop);
  result.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  count_and_unsubscribe(writer, channels, result, progress);
  write_timing(writer, browser, "rtm.timing.end");
  writer.close();
  result.bytes = writer.bytes_written();
  return result;
}

}  // namespace rtm::cli
