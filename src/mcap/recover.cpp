// SPDX-License-Identifier: Apache-2.0
// Reading an MCAP file from its start, for files without a summary: a killed writer, a file cut
// short, a damaged chunk. Everything before the first bad record is kept.
#include <fmt/format.h>

#include <cstring>
#include <map>

#include "parse.h"
#include "mcap/reader.h"
#include "mcap/writer.h"

namespace rtm::mcap {

using namespace detail;

namespace {

// One record of the data section, taken into `found`; throws FormatError if it is damaged.
// Returns false at the end of the data section.
bool take_record(Opcode op, Cursor& c, Recovered& found, const std::function<void(const Message&)>& on_message,
                 const std::string& path) {
  switch (op) {
    case Opcode::schema: found.schemas.push_back(parse_schema(c)); return true;
    case Opcode::channel: found.channels.push_back(parse_channel(c)); return true;
    case Opcode::message:
      on_message(parse_message(c));
      ++found.message_count;
      return true;
    case Opcode::metadata: found.metadata.push_back(parse_metadata(c)); return true;
    case Opcode::chunk: {
      const auto records = open_chunk(c, path);
      // A chunk is taken whole or not at all: its messages are given only once all are read.
      Recovered inner;
      std::vector<Message> messages;
      each_record(records, 0, [&](Opcode inner_op, Cursor& ic) {
        take_record(inner_op, ic, inner, [&](const Message& m) { messages.push_back(m); }, path);
      });
      for (auto& s : inner.schemas) found.schemas.push_back(std::move(s));
      for (auto& ch : inner.channels) found.channels.push_back(std::move(ch));
      for (const auto& m : messages) on_message(m);
      found.message_count += messages.size();
      ++found.chunk_count;
      return true;
    }
    case Opcode::data_end:
    case Opcode::footer: return false;
    default: return true;  // indexes, attachments, and records of later versions
  }
}

}  // namespace

Recovered recover(const std::string& path, const std::function<void(const Message&)>& on_message) {
  File file(path);
  Recovered found;
  Bytes buf;
  if (!file.read(0, sizeof kMagic, buf) || std::memcmp(buf.data(), kMagic, sizeof kMagic) != 0) {
    throw FormatError(fmt::format("{}: not an MCAP file (no magic at its start)", path));
  }
  std::uint64_t at = sizeof kMagic;
  bool first = true;
  while (true) {
    found.good_bytes = at;
    if (at == file.size()) {
      found.stopped_because = fmt::format("the file ends at byte {} with no data end or footer", at);
      return found;
    }
    if (!file.read(at, kRecordPrefix, buf)) {
      found.stopped_because = fmt::format("the record at byte {} is cut short", at);
      return found;
    }
    Cursor prefix(buf.data(), buf.size(), at);
    const auto op = static_cast<Opcode>(prefix.u8("record opcode"));
    const auto length = prefix.u64("record length");
    Bytes content;
    if (!file.read(at + kRecordPrefix, length, content)) {
      found.stopped_because = fmt::format("the record at byte {} is cut short (it claims {} bytes, {} are left)", at,
                                          length, file.size() - at - kRecordPrefix);
      return found;
    }
    Cursor c(content.data(), content.size(), at + kRecordPrefix);
    try {
      if (first) {
        if (op != Opcode::header) throw FormatError(fmt::format("{}: the first record is not a header", path));
        found.header = parse_header(c);
        first = false;
      } else if (!take_record(op, c, found, on_message, path)) {
        found.good_bytes = at;
        Bytes magic;
        found.complete = op == Opcode::data_end ||
                         (file.read(file.size() - sizeof kMagic, sizeof kMagic, magic) &&
                          std::memcmp(magic.data(), kMagic, sizeof kMagic) == 0);
        if (!found.complete) found.stopped_because = "the file has no closing magic";
        return found;
      }
    } catch (const FormatError& e) {
      if (first) throw;
      found.stopped_because = e.what();
      return found;
    }
    at += kRecordPrefix + length;
  }
}

Recovered recover_to(const std::string& damaged, const std::string& out) {
  // recover() gives each message after the records before it: a first pass learns the header,
  // schemas, channels and metadata; the second writes the messages.
  const auto first = recover(damaged, [](const Message&) {});
  WriterOptions options;
  options.profile = first.header.profile;
  Writer writer(out, options);
  std::map<std::uint16_t, std::uint16_t> schema_ids;  // the damaged file's -> out's
  for (const auto& s : first.schemas) {
    if (s.id != 0 && !schema_ids.contains(s.id)) schema_ids[s.id] = writer.add_schema(s.name, s.encoding, s.data);
  }
  std::map<std::uint16_t, std::uint16_t> channel_ids;
  for (const auto& c : first.channels) {
    if (channel_ids.contains(c.id)) continue;
    const auto schema = schema_ids.find(c.schema_id);
    channel_ids[c.id] = writer.add_channel(schema == schema_ids.end() ? 0 : schema->second, c.topic,
                                           c.message_encoding, c.metadata);
  }
  for (const auto& m : first.metadata) writer.add_metadata(m.name, m.values);
  const auto found = recover(damaged, [&](const Message& m) {
    const auto id = channel_ids.find(m.channel_id);
    if (id == channel_ids.end()) return;  // a message on a channel never declared: nothing to say what it is
    writer.write(id->second, m.sequence, m.log_time, m.publish_time, m.data);
  });
  writer.close();
  return found;
}

}  // namespace rtm::mcap
