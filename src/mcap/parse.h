// SPDX-License-Identifier: Apache-2.0
// What the indexed reader and recovery share: a file read with pread(), and the parsing of the
// data section's records.
#pragma once

#include <cstdint>
#include <string>

#include "bytes.h"

namespace rtm::mcap::detail {

inline constexpr std::size_t kRecordPrefix = 1 + sizeof(std::uint64_t);  // opcode, length

class File {
 public:
  // Throws std::system_error.
  explicit File(const std::string& path);
  ~File();
  File(const File&) = delete;
  File& operator=(const File&) = delete;

  const std::string& path() const { return path_; }
  std::uint64_t size() const { return size_; }
  // n bytes at offset into `out`, or false when the file holds fewer.
  bool read(std::uint64_t offset, std::uint64_t n, Bytes& out) const;
  // The same, or a FormatError saying what was expected there.
  Bytes read_exact(std::uint64_t offset, std::uint64_t n) const;

 private:
  std::string path_;
  int fd_ = -1;
  std::uint64_t size_ = 0;
};

Header parse_header(Cursor& c);
Schema parse_schema(Cursor& c);
Channel parse_channel(Cursor& c);
Message parse_message(Cursor& c);
Metadata parse_metadata(Cursor& c);
// A chunk's records, decompressed and checked against its CRC.
Bytes open_chunk(Cursor& c, const std::string& path);

// Calls on_record(opcode, content cursor) for each record of a span at file offset `base`.
template <typename F>
void each_record(const Bytes& span, std::uint64_t base, F&& on_record) {
  Cursor c(span.data(), span.size(), base);
  while (c.left() > 0) {
    const auto op = static_cast<Opcode>(c.u8("record opcode"));
    const auto length = c.u64("record length");
    const auto content_at = c.file_offset();
    const auto* p = c.bytes(length, "record content");
    Cursor content(p, length, content_at);
    on_record(op, content);
  }
}

}  // namespace rtm::mcap::detail
