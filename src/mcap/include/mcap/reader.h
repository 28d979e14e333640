// SPDX-License-Identifier: Apache-2.0
// Reads MCAP files two ways:
//   Reader   through the summary: schemas, channels, statistics and metadata without reading
//            the data; messages of a time range by seeking to the chunks that hold it.
//   recover  from the start, record by record, for a file with no summary (a writer that was
//            killed, a file cut short): everything up to the last whole, intact chunk.
// Files are read with pread(): a file that shrinks while it is read gives a FormatError, never
// a signal. Every length a file declares is checked against what is there before it is used.
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "mcap/records.h"

namespace rtm::mcap {

namespace detail {
class File;
}

struct ReadRange {
  std::uint64_t start_time = 0;                                     // ns, inclusive
  std::uint64_t end_time = std::numeric_limits<std::uint64_t>::max();  // ns, inclusive
};

class Reader {
 public:
  // Reads the footer and the summary. Throws std::system_error if the file cannot be opened,
  // FormatError if it is not an MCAP file with a summary (recover() reads one without).
  explicit Reader(const std::string& path);
  ~Reader();
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;

  const Header& header() const { return header_; }
  const std::vector<Schema>& schemas() const { return schemas_; }
  const std::vector<Channel>& channels() const { return channels_; }
  const Statistics& statistics() const { return statistics_; }
  const std::vector<ChunkIndex>& chunk_indexes() const { return chunk_indexes_; }
  const std::vector<MetadataIndex>& metadata_indexes() const { return metadata_indexes_; }

  const Schema* schema(std::uint16_t id) const;
  const Channel* channel(std::uint16_t id) const;
  const Channel* channel(const std::string& topic) const;

  // Each metadata record, read from where the index says.
  std::vector<Metadata> metadata() const;

  // Messages whose log time is in `range`, in log-time order (ties in file order), reading only
  // the chunks that overlap it. Each chunk's CRC is checked. Returns how many were given.
  std::uint64_t read_messages(const ReadRange& range, const std::function<void(const Message&)>& on_message) const;
  std::vector<Message> messages(const ReadRange& range = {}) const;

 private:
  void read_summary(std::uint64_t start, std::uint64_t end, std::uint32_t crc);

  std::unique_ptr<detail::File> file_;
  std::string path_;
  std::uint64_t size_ = 0;
  Header header_;
  std::vector<Schema> schemas_;
  std::vector<Channel> channels_;
  Statistics statistics_;
  std::vector<ChunkIndex> chunk_indexes_;
  std::vector<MetadataIndex> metadata_indexes_;
};

// What recover() found.
struct Recovered {
  Header header;
  std::vector<Schema> schemas;
  std::vector<Channel> channels;
  std::vector<Metadata> metadata;
  std::uint64_t message_count = 0;
  std::uint64_t chunk_count = 0;
  std::uint64_t good_bytes = 0;  // the file up to here is whole records, each read
  bool complete = false;         // the data section was read to its end: nothing was lost
  std::string stopped_because;   // why reading stopped before the end ("" when complete)
};

// Reads `path` from the start, giving each message to `on_message` in file order, and stops at
// the first record that is cut short or damaged (a chunk whose CRC or compression is wrong):
// what came before it is kept. Throws std::system_error if the file cannot be opened and
// FormatError if it does not even start as an MCAP file.
Recovered recover(const std::string& path, const std::function<void(const Message&)>& on_message);

// Writes what recover() finds in `damaged` as a whole file at `out` (a summary and indexes
// included). Returns what was found.
Recovered recover_to(const std::string& damaged, const std::string& out);

}  // namespace rtm::mcap
