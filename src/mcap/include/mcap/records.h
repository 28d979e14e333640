// SPDX-License-Identifier: Apache-2.0
// MCAP records (https://mcap.dev/spec, major version 0), written and read by this library
// alone: no MCAP library is packaged in Debian 12. Knows nothing of CORBA or of RTM's types: a
// schema's data and a message's data are bytes here.
//
// On disk every record is <opcode u8><content length u64><content>, little-endian; a string is
// <length u32><bytes>, a map <byte length u32><pairs>. Times are nanoseconds (the recorder
// writes a datum's own stamp as log time and its arrival as publish time).
#pragma once

#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace rtm::mcap {

// ---- Constants --------------------------------------------------------------------------------

inline constexpr char kMagic[8] = {'\x89', 'M', 'C', 'A', 'P', '0', '\r', '\n'};

enum class Opcode : std::uint8_t {
  header = 0x01,
  footer = 0x02,
  schema = 0x03,
  channel = 0x04,
  message = 0x05,
  chunk = 0x06,
  message_index = 0x07,
  chunk_index = 0x08,
  attachment = 0x09,
  attachment_index = 0x0A,
  statistics = 0x0B,
  metadata = 0x0C,
  metadata_index = 0x0D,
  summary_offset = 0x0E,
  data_end = 0x0F,
};

// A chunk's compression, by its name in the file ("" is none).
enum class Compression { none, lz4, zstd };
const char* compression_name(Compression c);
// Throws FormatError for a name this library cannot decompress.
Compression compression_from_name(const std::string& name);

// A file this library cannot read, or a record that breaks the specification. what() names the
// byte offset and what was wrong there.
class FormatError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

using KeyValues = std::map<std::string, std::string>;

// ---- Records ----------------------------------------------------------------------------------

struct Header {
  std::string profile;  // "" : no well-known profile
  std::string library;  // who wrote the file
};

struct Schema {
  std::uint16_t id = 0;  // 0 is not a valid schema id
  std::string name;      // e.g. "RTM::TimedFloat6"
  std::string encoding;  // e.g. "omgidl"
  std::string data;      // e.g. the IDL text the type needs
};

struct Channel {
  std::uint16_t id = 0;
  std::uint16_t schema_id = 0;   // 0: no schema
  std::string topic;             // e.g. "sensor0.out0"
  std::string message_encoding;  // e.g. "cdr"
  KeyValues metadata;
};

// A message as read: its data is a copy (a view would not outlive the chunk it came from).
struct Message {
  std::uint16_t channel_id = 0;
  std::uint32_t sequence = 0;
  std::uint64_t log_time = 0;      // ns
  std::uint64_t publish_time = 0;  // ns
  std::vector<std::uint8_t> data;
};

struct Metadata {
  std::string name;
  KeyValues values;
};

struct ChunkIndex {
  std::uint64_t message_start_time = 0;
  std::uint64_t message_end_time = 0;
  std::uint64_t chunk_start_offset = 0;  // file offset of the chunk record's opcode
  std::uint64_t chunk_length = 0;        // the whole record, opcode and length included
  std::map<std::uint16_t, std::uint64_t> message_index_offsets;  // channel -> file offset
  std::uint64_t message_index_length = 0;
  std::string compression;
  std::uint64_t compressed_size = 0;
  std::uint64_t uncompressed_size = 0;
};

struct MetadataIndex {
  std::uint64_t offset = 0;  // file offset of the metadata record
  std::uint64_t length = 0;  // the whole record
  std::string name;
};

struct Statistics {
  std::uint64_t message_count = 0;
  std::uint16_t schema_count = 0;
  std::uint32_t channel_count = 0;
  std::uint32_t attachment_count = 0;
  std::uint32_t metadata_count = 0;
  std::uint32_t chunk_count = 0;
  std::uint64_t message_start_time = 0;
  std::uint64_t message_end_time = 0;
  std::map<std::uint16_t, std::uint64_t> channel_message_counts;
};

}  // namespace rtm::mcap
