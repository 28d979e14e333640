// SPDX-License-Identifier: Apache-2.0
#include "mcap/writer.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <stdexcept>
#include <system_error>

#include "bytes.h"

namespace rtm::mcap {

using namespace detail;

namespace {

void put_schema(Bytes& out, const Schema& s) {
  const auto at = begin_record(out, Opcode::schema);
  put_u16(out, s.id);
  put_string(out, s.name);
  put_string(out, s.encoding);
  put_string(out, s.data);  // bytes: the same <u32 length><data>
  end_record(out, at);
}

void put_channel(Bytes& out, const Channel& c) {
  const auto at = begin_record(out, Opcode::channel);
  put_u16(out, c.id);
  put_u16(out, c.schema_id);
  put_string(out, c.topic);
  put_string(out, c.message_encoding);
  put_key_values(out, c.metadata);
  end_record(out, at);
}

void put_chunk_index(Bytes& out, const ChunkIndex& ci) {
  const auto at = begin_record(out, Opcode::chunk_index);
  put_u64(out, ci.message_start_time);
  put_u64(out, ci.message_end_time);
  put_u64(out, ci.chunk_start_offset);
  put_u64(out, ci.chunk_length);
  put_id_counts(out, ci.message_index_offsets);
  put_u64(out, ci.message_index_length);
  put_string(out, ci.compression);
  put_u64(out, ci.compressed_size);
  put_u64(out, ci.uncompressed_size);
  end_record(out, at);
}

void put_statistics(Bytes& out, const Statistics& s) {
  const auto at = begin_record(out, Opcode::statistics);
  put_u64(out, s.message_count);
  put_u16(out, s.schema_count);
  put_u32(out, s.channel_count);
  put_u32(out, s.attachment_count);
  put_u32(out, s.metadata_count);
  put_u32(out, s.chunk_count);
  put_u64(out, s.message_start_time);
  put_u64(out, s.message_end_time);
  put_id_counts(out, s.channel_message_counts);
  end_record(out, at);
}

}  // namespace

Writer::Writer(const std::string& path, WriterOptions options) : path_(path), options_(std::move(options)) {
  const int exclusive = options_.replace ? O_TRUNC : O_EXCL;
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_NOFOLLOW | O_CLOEXEC | exclusive, options_.mode);
  if (fd_ < 0) {
    const int e = errno;
    throw std::system_error(e, std::generic_category(),
                            fmt::format("cannot create {}{}", path, e == ELOOP ? " (it is a symbolic link)" : ""));
  }
  if (::fchmod(fd_, options_.mode) != 0) {  // a file it replaced keeps its mode otherwise
    const int e = errno;
    ::close(fd_);
    throw std::system_error(e, std::generic_category(), fmt::format("cannot set the mode of {}", path));
  }
  Bytes start;
  put_raw(start, kMagic, sizeof kMagic);
  const auto at = begin_record(start, Opcode::header);
  put_string(start, options_.profile);
  put_string(start, options_.library);
  end_record(start, at);
  write_out(start, true);
}

Writer::~Writer() {
  try {
    close();
  } catch (...) {  // NOLINT(bugprone-empty-catch): a destructor cannot report; close() does
  }
  if (fd_ >= 0) ::close(fd_);
}

void Writer::write_out(const Bytes& bytes, bool in_data_section) {
  if (in_data_section) data_crc_ = crc32(data_crc_, bytes.data(), bytes.size());
  std::size_t done = 0;
  while (done < bytes.size()) {
    const auto n = ::write(fd_, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw std::system_error(errno, std::generic_category(), fmt::format("cannot write {}", path_));
    done += static_cast<std::size_t>(n);
  }
  offset_ += bytes.size();
}

std::uint16_t Writer::add_schema(const std::string& name, const std::string& encoding, const std::string& data) {
  if (schemas_.size() >= 0xFFFF) throw std::length_error("an MCAP file holds at most 65535 schemas");
  auto& s = schemas_.emplace_back(Schema{static_cast<std::uint16_t>(schemas_.size() + 1), name, encoding, data});
  Bytes out;
  put_schema(out, s);
  write_out(out, true);
  stats_.schema_count = static_cast<std::uint16_t>(schemas_.size());
  return s.id;
}

std::uint16_t Writer::add_channel(std::uint16_t schema_id, const std::string& topic,
                                  const std::string& message_encoding, const KeyValues& metadata) {
  if (schema_id > schemas_.size()) throw std::invalid_argument(fmt::format("no schema {} in {}", schema_id, path_));
  if (channels_.size() >= 0xFFFF) throw std::length_error("an MCAP file holds at most 65535 channels");
  auto& c = channels_.emplace_back(
      Channel{static_cast<std::uint16_t>(channels_.size() + 1), schema_id, topic, message_encoding, metadata});
  Bytes out;
  put_channel(out, c);
  write_out(out, true);
  stats_.channel_count = static_cast<std::uint32_t>(channels_.size());
  return c.id;
}

void Writer::add_metadata(const std::string& name, const KeyValues& values) {
  Bytes out;
  const auto at = begin_record(out, Opcode::metadata);
  put_string(out, name);
  put_key_values(out, values);
  end_record(out, at);
  metadata_indexes_.push_back(MetadataIndex{offset_, out.size(), name});
  write_out(out, true);
  ++stats_.metadata_count;
}

void Writer::write(std::uint16_t channel_id, std::uint32_t sequence, std::uint64_t log_time,
                   std::uint64_t publish_time, std::span<const std::uint8_t> data) {
  if (channel_id == 0 || channel_id > channels_.size()) {
    throw std::invalid_argument(fmt::format("no channel {} in {}", channel_id, path_));
  }
  if (chunk_.empty()) {
    chunk_start_time_ = log_time;
    chunk_end_time_ = log_time;
  }
  chunk_start_time_ = std::min(chunk_start_time_, log_time);
  chunk_end_time_ = std::max(chunk_end_time_, log_time);
  chunk_index_entries_[channel_id].emplace_back(log_time, chunk_.size());
  const auto at = begin_record(chunk_, Opcode::message);
  put_u16(chunk_, channel_id);
  put_u32(chunk_, sequence);
  put_u64(chunk_, log_time);
  put_u64(chunk_, publish_time);
  put_raw(chunk_, data.data(), data.size());
  end_record(chunk_, at);

  if (stats_.message_count == 0) stats_.message_start_time = stats_.message_end_time = log_time;
  stats_.message_start_time = std::min(stats_.message_start_time, log_time);
  stats_.message_end_time = std::max(stats_.message_end_time, log_time);
  ++stats_.message_count;
  ++stats_.channel_message_counts[channel_id];
  if (chunk_.size() >= options_.chunk_size) write_chunk();
}

void Writer::flush() {
  if (!chunk_.empty()) write_chunk();
}

// The chunk, then one message index per channel in it, in one write().
void Writer::write_chunk() {
  ChunkIndex ci;
  ci.message_start_time = chunk_start_time_;
  ci.message_end_time = chunk_end_time_;
  ci.chunk_start_offset = offset_;
  ci.compression = compression_name(options_.compression);
  ci.uncompressed_size = chunk_.size();

  scratch_.clear();
  const auto at = begin_record(scratch_, Opcode::chunk);
  put_u64(scratch_, chunk_start_time_);
  put_u64(scratch_, chunk_end_time_);
  put_u64(scratch_, chunk_.size());
  put_u32(scratch_, crc32(0, chunk_.data(), chunk_.size()));
  put_string(scratch_, ci.compression);
  const auto size_at = scratch_.size();
  put_u64(scratch_, 0);
  compress(options_.compression, chunk_, scratch_);
  ci.compressed_size = scratch_.size() - size_at - sizeof(std::uint64_t);
  std::memcpy(scratch_.data() + size_at, &ci.compressed_size, sizeof ci.compressed_size);
  end_record(scratch_, at);
  ci.chunk_length = scratch_.size();

  for (const auto& [channel, entries] : chunk_index_entries_) {
    ci.message_index_offsets[channel] = offset_ + scratch_.size();
    const auto index_at = begin_record(scratch_, Opcode::message_index);
    put_u16(scratch_, channel);
    put_u32(scratch_, static_cast<std::uint32_t>(entries.size() * 2 * sizeof(std::uint64_t)));
    for (const auto& [time, offset] : entries) {
      put_u64(scratch_, time);
      put_u64(scratch_, offset);
    }
    end_record(scratch_, index_at);
  }
  ci.message_index_length = scratch_.size() - ci.chunk_length;
  write_out(scratch_, true);

  chunk_indexes_.push_back(std::move(ci));
  ++stats_.chunk_count;
  chunk_.clear();
  chunk_index_entries_.clear();
}

// The summary section's groups, each followed by nothing else of its kind, then their offsets.
Bytes Writer::summary(std::uint64_t summary_start, std::uint64_t& offsets_start) {
  Bytes out;
  struct Group {
    Opcode opcode;
    std::size_t start;
    std::size_t length;
  };
  std::vector<Group> groups;
  const auto group = [&](Opcode op, auto&& write_records) {
    const auto start = out.size();
    write_records();
    if (out.size() > start) groups.push_back(Group{op, start, out.size() - start});
  };
  group(Opcode::schema, [&] {
    for (const auto& s : schemas_) put_schema(out, s);
  });
  group(Opcode::channel, [&] {
    for (const auto& c : channels_) put_channel(out, c);
  });
  group(Opcode::statistics, [&] { put_statistics(out, stats_); });
  group(Opcode::chunk_index, [&] {
    for (const auto& ci : chunk_indexes_) put_chunk_index(out, ci);
  });
  group(Opcode::metadata_index, [&] {
    for (const auto& mi : metadata_indexes_) {
      const auto at = begin_record(out, Opcode::metadata_index);
      put_u64(out, mi.offset);
      put_u64(out, mi.length);
      put_string(out, mi.name);
      end_record(out, at);
    }
  });
  offsets_start = summary_start + out.size();
  for (const auto& g : groups) {
    const auto at = begin_record(out, Opcode::summary_offset);
    put_u8(out, static_cast<std::uint8_t>(g.opcode));
    put_u64(out, summary_start + g.start);
    put_u64(out, g.length);
    end_record(out, at);
  }
  return out;
}

void Writer::close() {
  if (fd_ < 0) return;
  flush();
  Bytes end;
  const auto at = begin_record(end, Opcode::data_end);
  put_u32(end, data_crc_);
  end_record(end, at);
  write_out(end, false);

  const auto summary_start = offset_;
  std::uint64_t offsets_start = 0;
  Bytes tail = summary(summary_start, offsets_start);
  put_u8(tail, static_cast<std::uint8_t>(Opcode::footer));
  put_u64(tail, 8 + 8 + 4);  // its length is known: the CRC below covers it
  put_u64(tail, summary_start);
  put_u64(tail, offsets_start);
  put_u32(tail, crc32(0, tail.data(), tail.size()));  // the summary, its offsets, the footer so far
  put_raw(tail, kMagic, sizeof kMagic);
  write_out(tail, false);

  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) throw std::system_error(errno, std::generic_category(), fmt::format("cannot close {}", path_));
}

}  // namespace rtm::mcap
