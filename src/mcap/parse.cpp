// SPDX-License-Identifier: Apache-2.0
#include "parse.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <system_error>

namespace rtm::mcap::detail {

File::File(const std::string& path) : path_(path) {
  fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd_ < 0) throw std::system_error(errno, std::generic_category(), fmt::format("cannot open {}", path));
  struct stat st {};
  if (::fstat(fd_, &st) != 0) {
    const int e = errno;
    ::close(fd_);
    throw std::system_error(e, std::generic_category(), fmt::format("cannot stat {}", path));
  }
  size_ = static_cast<std::uint64_t>(st.st_size);
}

File::~File() { ::close(fd_); }

bool File::read(std::uint64_t offset, std::uint64_t n, Bytes& out) const {
  if (offset > size_ || n > size_ - offset) return false;
  out.resize(n);
  std::uint64_t done = 0;
  while (done < n) {
    const auto got = ::pread(fd_, out.data() + done, n - done, static_cast<off_t>(offset + done));
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) throw std::system_error(errno, std::generic_category(), fmt::format("cannot read {}", path_));
    if (got == 0) return false;  // the file shrank
    done += static_cast<std::uint64_t>(got);
  }
  return true;
}

Bytes File::read_exact(std::uint64_t offset, std::uint64_t n) const {
  Bytes out;
  if (!read(offset, n, out)) {
    throw FormatError(fmt::format("{}: {} bytes at byte {} were expected, the file has {}", path_, n, offset, size_));
  }
  return out;
}

Header parse_header(Cursor& c) {
  Header h;
  h.profile = c.string("header profile");
  h.library = c.string("header library");
  return h;
}

Schema parse_schema(Cursor& c) {
  Schema s;
  s.id = c.u16("schema id");
  s.name = c.string("schema name");
  s.encoding = c.string("schema encoding");
  s.data = c.string("schema data");
  return s;
}

Channel parse_channel(Cursor& c) {
  Channel ch;
  ch.id = c.u16("channel id");
  ch.schema_id = c.u16("channel schema id");
  ch.topic = c.string("channel topic");
  ch.message_encoding = c.string("channel message encoding");
  ch.metadata = c.key_values("channel metadata");
  return ch;
}

Message parse_message(Cursor& c) {
  Message m;
  m.channel_id = c.u16("message channel id");
  m.sequence = c.u32("message sequence");
  m.log_time = c.u64("message log time");
  m.publish_time = c.u64("message publish time");
  const auto n = c.left();
  const auto* p = c.bytes(n, "message data");
  m.data.assign(p, p + n);
  return m;
}

Metadata parse_metadata(Cursor& c) {
  Metadata m;
  m.name = c.string("metadata name");
  m.values = c.key_values("metadata");
  return m;
}

Bytes open_chunk(Cursor& c, const std::string& path) {
  const std::string where = fmt::format("{}: the chunk at byte {}", path, c.file_offset() - kRecordPrefix);
  c.u64("chunk message start time");
  c.u64("chunk message end time");
  const auto uncompressed_size = c.u64("chunk uncompressed size");
  const auto crc = c.u32("chunk uncompressed crc");
  const auto compression = compression_from_name(c.string("chunk compression"));
  const auto n = c.u64("chunk records length");
  const auto* p = c.bytes(n, "chunk records");
  Bytes records = decompress(compression, p, n, uncompressed_size, where);
  if (crc != 0 && crc32(0, records.data(), records.size()) != crc) {
    throw FormatError(fmt::format("{}: its records do not match their CRC", where));
  }
  return records;
}

}  // namespace rtm::mcap::detail
