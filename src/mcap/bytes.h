// SPDX-License-Identifier: Apache-2.0
// Little-endian encoding of MCAP's primitives, and a bounds-checked cursor to read them back:
// every read past the end throws FormatError naming the file offset and the field.
#pragma once

#include <bit>
#include <cstdint>
#include <cstring>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "mcap/records.h"

namespace rtm::mcap::detail {

using Bytes = std::vector<std::uint8_t>;

inline void put_u8(Bytes& out, std::uint8_t v) { out.push_back(v); }
template <typename T>
void put_le(Bytes& out, T v) {
  static_assert(std::endian::native == std::endian::little, "MCAP is little-endian; so is this host");
  const auto at = out.size();
  out.resize(at + sizeof v);
  std::memcpy(out.data() + at, &v, sizeof v);
}
inline void put_u16(Bytes& out, std::uint16_t v) { put_le(out, v); }
inline void put_u32(Bytes& out, std::uint32_t v) { put_le(out, v); }
inline void put_u64(Bytes& out, std::uint64_t v) { put_le(out, v); }
inline void put_raw(Bytes& out, const void* data, std::size_t n) {
  if (n == 0) return;
  const auto at = out.size();
  out.resize(at + n);
  std::memcpy(out.data() + at, data, n);
}
inline void put_string(Bytes& out, std::string_view s) {
  put_u32(out, static_cast<std::uint32_t>(s.size()));
  put_raw(out, s.data(), s.size());
}
void put_key_values(Bytes& out, const KeyValues& kv);
void put_id_counts(Bytes& out, const std::map<std::uint16_t, std::uint64_t>& m);

// A record's frame: the opcode, then a placeholder length that end_record() fills in.
inline std::size_t begin_record(Bytes& out, Opcode op) {
  put_u8(out, static_cast<std::uint8_t>(op));
  put_u64(out, 0);
  return out.size();
}
inline void end_record(Bytes& out, std::size_t content_start) {
  const std::uint64_t length = out.size() - content_start;
  std::memcpy(out.data() + content_start - sizeof length, &length, sizeof length);
}

// Reads one record's content (or any span of a file); `base` is the span's offset in the file,
// for the errors.
class Cursor {
 public:
  Cursor(const std::uint8_t* data, std::size_t size, std::uint64_t base)
      : data_(data), size_(size), base_(base) {}

  std::uint8_t u8(const char* field) { return get<std::uint8_t>(field); }
  std::uint16_t u16(const char* field) { return get<std::uint16_t>(field); }
  std::uint32_t u32(const char* field) { return get<std::uint32_t>(field); }
  std::uint64_t u64(const char* field) { return get<std::uint64_t>(field); }
  std::string string(const char* field);
  // n bytes, as a view into the span.
  const std::uint8_t* bytes(std::uint64_t n, const char* field);
  KeyValues key_values(const char* field);
  std::map<std::uint16_t, std::uint64_t> id_counts(const char* field);

  std::size_t left() const { return size_ - at_; }
  std::size_t position() const { return at_; }
  std::uint64_t file_offset() const { return base_ + at_; }

 private:
  template <typename T>
  T get(const char* field) {
    need(sizeof(T), field);
    T v;
    std::memcpy(&v, data_ + at_, sizeof v);
    at_ += sizeof v;
    return v;
  }
  void need(std::uint64_t n, const char* field) const;

  const std::uint8_t* data_;
  std::size_t size_;
  std::uint64_t base_;
  std::size_t at_ = 0;
};

// CRC-32 (ISO-HDLC, as zlib computes it), continued from `crc`.
std::uint32_t crc32(std::uint32_t crc, const void* data, std::size_t n);

// Chunk compression. compress() appends to `out`; decompress() returns exactly
// `uncompressed_size` bytes or throws FormatError (naming `where`).
void compress(Compression c, const Bytes& in, Bytes& out);
Bytes decompress(Compression c, const std::uint8_t* in, std::size_t n, std::uint64_t uncompressed_size,
                 const std::string& where);

}  // namespace rtm::mcap::detail
