// SPDX-License-Identifier: Apache-2.0
// Writes an MCAP file: messages in compressed chunks, each followed by its message indexes; on
// close() the summary (schemas, channels, statistics, chunk and metadata indexes) and its
// offsets, so a reader can seek by time without reading the data.
//
// Durability: schemas, channels and metadata go to the file as they are added, and a chunk goes
// in one write when it is full, so a writer that is killed leaves a file that recover()
// (reader.h) reads up to its last whole chunk. Not thread-safe: one thread writes.
#pragma once

#include <cstdint>
#include <map>
#include <span>
#include <string>
#include <vector>

#include "mcap/records.h"

namespace rtm::mcap {

struct WriterOptions {
  Compression compression = Compression::zstd;
  std::size_t chunk_size = 1 << 20;  // bytes of records before a chunk is compressed and written
  std::string profile;               // the header's profile
  std::string library = "rtm";       // the header's library
  unsigned mode = 0600;              // of the file, also when it replaces one: its owner's alone
  bool replace = true;               // else a file already there is refused (O_EXCL)
};

class Writer {
 public:
  // Creates (or, with options.replace, truncates) `path` with options.mode. Never through a
  // symbolic link (one planted where the file goes is refused). Throws std::system_error.
  Writer(const std::string& path, WriterOptions options = {});
  // Closes the file if close() was not called, dropping any error (call close() to see it).
  ~Writer();
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  // Ids are given in order from 1.
  std::uint16_t add_schema(const std::string& name, const std::string& encoding, const std::string& data);
  std::uint16_t add_channel(std::uint16_t schema_id, const std::string& topic, const std::string& message_encoding,
                            const KeyValues& metadata = {});
  void add_metadata(const std::string& name, const KeyValues& values);

  // Throws std::invalid_argument for a channel never added.
  void write(std::uint16_t channel_id, std::uint32_t sequence, std::uint64_t log_time, std::uint64_t publish_time,
             std::span<const std::uint8_t> data);

  // Writes the open chunk now (its messages survive a kill from here on).
  void flush();
  // The rest: the open chunk, the data end, the summary, the footer. Idempotent.
  void close();

  std::uint64_t bytes_written() const { return offset_; }
  const Statistics& statistics() const { return stats_; }

 private:
  void write_out(const std::vector<std::uint8_t>& bytes, bool in_data_section);
  void write_chunk();
  std::vector<std::uint8_t> summary(std::uint64_t summary_start, std::uint64_t& offsets_start);

  int fd_ = -1;
  std::string path_;
  WriterOptions options_;
  std::uint64_t offset_ = 0;  // bytes in the file so far
  std::uint32_t data_crc_ = 0;

  std::vector<Schema> schemas_;
  std::vector<Channel> channels_;
  std::vector<MetadataIndex> metadata_indexes_;
  std::vector<ChunkIndex> chunk_indexes_;
  Statistics stats_;

  // The open chunk.
  std::vector<std::uint8_t> chunk_;
  std::map<std::uint16_t, std::vector<std::pair<std::uint64_t, std::uint64_t>>> chunk_index_entries_;
  std::uint64_t chunk_start_time_ = 0;
  std::uint64_t chunk_end_time_ = 0;
  std::vector<std::uint8_t> scratch_;  // compressed chunk and its indexes, reused
};

}  // namespace rtm::mcap
