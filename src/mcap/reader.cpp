// SPDX-License-Identifier: Apache-2.0
#include "mcap/reader.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstring>
#include <queue>

#include "parse.h"

namespace rtm::mcap {

using namespace detail;

namespace {

constexpr std::size_t kFooterContent = 8 + 8 + 4;
// A summary beyond this is not one this library wrote, nor one worth loading whole.
constexpr std::uint64_t kMaxSummaryBytes = std::uint64_t{256} << 20;

}  // namespace

Reader::Reader(const std::string& path) : path_(path) {
  file_ = std::make_unique<File>(path);
  size_ = file_->size();
  constexpr std::uint64_t kTail = kRecordPrefix + kFooterContent + sizeof kMagic;
  if (size_ < sizeof kMagic + kTail) {
    throw FormatError(fmt::format("{}: {} bytes is too short for an MCAP file", path, size_));
  }
  const auto head = file_->read_exact(0, sizeof kMagic);
  const auto tail = file_->read_exact(size_ - kTail, kTail);
  if (std::memcmp(head.data(), kMagic, sizeof kMagic) != 0) {
    throw FormatError(fmt::format("{}: not an MCAP file (no magic at its start)", path));
  }
  if (std::memcmp(tail.data() + kTail - sizeof kMagic, kMagic, sizeof kMagic) != 0 ||
      tail[0] != static_cast<std::uint8_t>(Opcode::footer)) {
    throw FormatError(fmt::format("{}: has no footer: it was not closed (recover it with rtm record --recover)", path));
  }
  Cursor footer(tail.data() + kRecordPrefix, kFooterContent, size_ - kTail + kRecordPrefix);
  const auto summary_start = footer.u64("footer summary start");
  footer.u64("footer summary offset start");
  const auto summary_crc = footer.u32("footer summary crc");
  if (summary_start == 0) throw FormatError(fmt::format("{}: has no summary to seek with", path));
  read_summary(summary_start, size_ - kTail, summary_crc);

  // The header, for its profile and library.
  const auto prefix = file_->read_exact(sizeof kMagic, kRecordPrefix);
  Cursor hp(prefix.data(), prefix.size(), sizeof kMagic);
  if (static_cast<Opcode>(hp.u8("opcode")) != Opcode::header) {
    throw FormatError(fmt::format("{}: the first record is not a header", path));
  }
  const auto length = hp.u64("header length");
  if (length > size_) throw FormatError(fmt::format("{}: the header claims {} bytes", path, length));
  const auto content = file_->read_exact(sizeof kMagic + kRecordPrefix, length);
  Cursor hc(content.data(), content.size(), sizeof kMagic + kRecordPrefix);
  header_ = parse_header(hc);
}

Reader::~Reader() = default;

void Reader::read_summary(std::uint64_t start, std::uint64_t end, std::uint32_t crc) {
  if (start < sizeof kMagic || start > end || end - start > kMaxSummaryBytes) {
    throw FormatError(fmt::format("{}: the footer puts the summary at byte {}, outside the file's {} bytes", path_,
                                  start, end));
  }
  auto span = file_->read_exact(start, end - start);
  if (crc != 0) {
    // The summary, its offsets and the footer up to its CRC.
    const auto footer = file_->read_exact(end, kRecordPrefix + 16);
    const auto got = crc32(crc32(0, span.data(), span.size()), footer.data(), footer.size());
    if (got != crc) throw FormatError(fmt::format("{}: the summary does not match its CRC", path_));
  }
  each_record(span, start, [&](Opcode op, Cursor& c) {
    switch (op) {
      case Opcode::schema: schemas_.push_back(parse_schema(c)); break;
      case Opcode::channel: channels_.push_back(parse_channel(c)); break;
      case Opcode::statistics: {
        auto& s = statistics_;
        s.message_count = c.u64("statistics message count");
        s.schema_count = c.u16("statistics schema count");
        s.channel_count = c.u32("statistics channel count");
        s.attachment_count = c.u32("statistics attachment count");
        s.metadata_count = c.u32("statistics metadata count");
        s.chunk_count = c.u32("statistics chunk count");
        s.message_start_time = c.u64("statistics message start time");
        s.message_end_time = c.u64("statistics message end time");
        s.channel_message_counts = c.id_counts("statistics channel message counts");
        break;
      }
      case Opcode::chunk_index: {
        ChunkIndex ci;
        ci.message_start_time = c.u64("chunk index message start time");
        ci.message_end_time = c.u64("chunk index message end time");
        ci.chunk_start_offset = c.u64("chunk index chunk start offset");
        ci.chunk_length = c.u64("chunk index chunk length");
        ci.message_index_offsets = c.id_counts("chunk index message index offsets");
        ci.message_index_length = c.u64("chunk index message index length");
        ci.compression = c.string("chunk index compression");
        ci.compressed_size = c.u64("chunk index compressed size");
        ci.uncompressed_size = c.u64("chunk index uncompressed size");
        if (ci.chunk_start_offset > size_ || ci.chunk_length > size_ - ci.chunk_start_offset) {
          throw FormatError(fmt::format("{}: a chunk index points past the end of the file", path_));
        }
        chunk_indexes_.push_back(std::move(ci));
        break;
      }
      case Opcode::metadata_index: {
        MetadataIndex mi;
        mi.offset = c.u64("metadata index offset");
        mi.length = c.u64("metadata index length");
        mi.name = c.string("metadata index name");
        if (mi.offset > size_ || mi.length > size_ - mi.offset) {
          throw FormatError(fmt::format("{}: a metadata index points past the end of the file", path_));
        }
        metadata_indexes_.push_back(std::move(mi));
        break;
      }
      default: break;  // summary offsets, attachment indexes, and records of later versions
    }
  });
  std::stable_sort(chunk_indexes_.begin(), chunk_indexes_.end(),
                   [](const ChunkIndex& a, const ChunkIndex& b) { return a.message_start_time < b.message_start_time; });
}

const Schema* Reader::schema(std::uint16_t id) const {
  for (const auto& s : schemas_)
    if (s.id == id) return &s;
  return nullptr;
}

const Channel* Reader::channel(std::uint16_t id) const {
  for (const auto& c : channels_)
    if (c.id == id) return &c;
  return nullptr;
}

const Channel* Reader::channel(const std::string& topic) const {
  for (const auto& c : channels_)
    if (c.topic == topic) return &c;
  return nullptr;
}

std::vector<Metadata> Reader::metadata() const {
  std::vector<Metadata> out;
  for (const auto& mi : metadata_indexes_) {
    const auto record = file_->read_exact(mi.offset, mi.length);
    each_record(record, mi.offset, [&](Opcode op, Cursor& c) {
      if (op != Opcode::metadata) {
        throw FormatError(fmt::format("{}: the metadata index for \"{}\" points at another record", path_, mi.name));
      }
      out.push_back(parse_metadata(c));
    });
  }
  return out;
}

std::uint64_t Reader::read_messages(const ReadRange& range,
                                    const std::function<void(const Message&)>& on_message) const {
  // Chunks may overlap in time: a message is given once no chunk still unread can hold an
  // earlier one (chunks are read in order of their first message).
  struct Pending {
    Message message;
    std::uint64_t order;
  };
  const auto later = [](const Pending& a, const Pending& b) {
    return a.message.log_time != b.message.log_time ? a.message.log_time > b.message.log_time : a.order > b.order;
  };
  std::priority_queue<Pending, std::vector<Pending>, decltype(later)> pending(later);
  std::uint64_t order = 0;
  std::uint64_t given = 0;
  const auto give_before = [&](std::uint64_t time) {
    while (!pending.empty() && pending.top().message.log_time < time) {
      on_message(pending.top().message);
      pending.pop();
      ++given;
    }
  };
  for (const auto& ci : chunk_indexes_) {
    if (ci.message_end_time < range.start_time || ci.message_start_time > range.end_time) continue;
    give_before(ci.message_start_time);
    const auto record = file_->read_exact(ci.chunk_start_offset, ci.chunk_length);
    each_record(record, ci.chunk_start_offset, [&](Opcode op, Cursor& c) {
      if (op != Opcode::chunk) throw FormatError(fmt::format("{}: a chunk index points at another record", path_));
      const auto records = open_chunk(c, path_);
      each_record(records, 0, [&](Opcode inner, Cursor& m) {
        if (inner != Opcode::message) return;
        auto message = parse_message(m);
        if (message.log_time < range.start_time || message.log_time > range.end_time) return;
        pending.push(Pending{std::move(message), order++});
      });
    });
  }
  while (!pending.empty()) {  // the rest, in order
    on_message(pending.top().message);
    pending.pop();
    ++given;
  }
  return given;
}

std::vector<Message> Reader::messages(const ReadRange& range) const {
  std::vector<Message> out;
  read_messages(range, [&](const Message& m) { out.push_back(m); });
  return out;
}

}  // namespace rtm::mcap
