// SPDX-License-Identifier: Apache-2.0
#include "bytes.h"

#include <fmt/format.h>
#include <lz4frame.h>
#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <memory>

namespace rtm::mcap {

const char* compression_name(Compression c) {
  switch (c) {
    case Compression::lz4: return "lz4";
    case Compression::zstd: return "zstd";
    case Compression::none: break;
  }
  return "";
}

Compression compression_from_name(const std::string& name) {
  if (name.empty()) return Compression::none;
  if (name == "lz4") return Compression::lz4;
  if (name == "zstd") return Compression::zstd;
  throw FormatError(fmt::format("unknown chunk compression \"{}\" (this reader takes \"\", lz4 and zstd)", name));
}

}  // namespace rtm::mcap

namespace rtm::mcap::detail {

void put_key_values(Bytes& out, const KeyValues& kv) {
  Bytes pairs;
  for (const auto& [k, v] : kv) {
    put_string(pairs, k);
    put_string(pairs, v);
  }
  put_u32(out, static_cast<std::uint32_t>(pairs.size()));
  put_raw(out, pairs.data(), pairs.size());
}

void put_id_counts(Bytes& out, const std::map<std::uint16_t, std::uint64_t>& m) {
  put_u32(out, static_cast<std::uint32_t>(m.size() * (sizeof(std::uint16_t) + sizeof(std::uint64_t))));
  for (const auto& [id, n] : m) {
    put_u16(out, id);
    put_u64(out, n);
  }
}

void Cursor::need(std::uint64_t n, const char* field) const {
  if (n > size_ - at_) {
    throw FormatError(fmt::format("at byte {}: {} needs {} bytes, the record has {} left", file_offset(), field, n,
                                  size_ - at_));
  }
}

std::string Cursor::string(const char* field) {
  const auto n = u32(field);
  const auto* p = bytes(n, field);
  return {reinterpret_cast<const char*>(p), n};
}

const std::uint8_t* Cursor::bytes(std::uint64_t n, const char* field) {
  need(n, field);
  const auto* p = data_ + at_;
  at_ += n;
  return p;
}

KeyValues Cursor::key_values(const char* field) {
  const auto n = u32(field);
  need(n, field);
  Cursor pairs(data_ + at_, n, file_offset());
  at_ += n;
  KeyValues kv;
  while (pairs.left() > 0) {
    auto key = pairs.string(field);
    kv[std::move(key)] = pairs.string(field);
  }
  return kv;
}

std::map<std::uint16_t, std::uint64_t> Cursor::id_counts(const char* field) {
  const auto n = u32(field);
  need(n, field);
  Cursor pairs(data_ + at_, n, file_offset());
  at_ += n;
  std::map<std::uint16_t, std::uint64_t> m;
  while (pairs.left() > 0) {
    const auto id = pairs.u16(field);
    m[id] = pairs.u64(field);
  }
  return m;
}

std::uint32_t crc32(std::uint32_t crc, const void* data, std::size_t n) {
  return static_cast<std::uint32_t>(::crc32_z(crc, static_cast<const Bytef*>(data), n));
}

namespace {

// zstd's fastest standard level: the recorder keeps up with many ports; level 1 still shrinks
// the demo's data about 4-fold.
constexpr int kZstdLevel = 1;

void compress_lz4(const Bytes& in, Bytes& out) {
  LZ4F_preferences_t prefs{};
  prefs.frameInfo.contentSize = in.size();  // lets a reader size its buffer once
  const auto at = out.size();
  out.resize(at + LZ4F_compressFrameBound(in.size(), &prefs));
  const auto n = LZ4F_compressFrame(out.data() + at, out.size() - at, in.data(), in.size(), &prefs);
  if (LZ4F_isError(n)) throw std::runtime_error(fmt::format("lz4 compression failed: {}", LZ4F_getErrorName(n)));
  out.resize(at + n);
}

void compress_zstd(const Bytes& in, Bytes& out) {
  const auto at = out.size();
  out.resize(at + ZSTD_compressBound(in.size()));
  const auto n = ZSTD_compress(out.data() + at, out.size() - at, in.data(), in.size(), kZstdLevel);
  if (ZSTD_isError(n)) throw std::runtime_error(fmt::format("zstd compression failed: {}", ZSTD_getErrorName(n)));
  out.resize(at + n);
}

// The output grows as the frame yields data, never past what the chunk declares: a chunk that
// lies about its size costs what it holds, not what it says.
void make_room(Bytes& out, std::size_t used, std::size_t declared) {
  if (used == out.size() && out.size() < declared) {
    out.resize(std::min(declared, std::max<std::size_t>(2 * out.size(), 64 * 1024)));
  }
}

[[noreturn]] void stuck(const std::string& where, const char* codec, std::size_t declared) {
  throw FormatError(fmt::format("{}: the {} frame ends early or holds more than the {} bytes the chunk declares",
                                where, codec, declared));
}

void check_whole(std::size_t got, std::size_t declared, std::size_t in_used, std::size_t n, const std::string& where,
                 const char* codec) {
  if (got != declared || in_used != n) {
    throw FormatError(fmt::format("{}: the {} frame gives {} bytes from {} of its {}, the chunk declares {}", where,
                                  codec, got, in_used, n, declared));
  }
}

Bytes decompress_lz4(const std::uint8_t* in, std::size_t n, std::size_t declared, const std::string& where) {
  LZ4F_dctx* raw = nullptr;
  if (LZ4F_isError(LZ4F_createDecompressionContext(&raw, LZ4F_VERSION))) throw std::bad_alloc();
  const std::unique_ptr<LZ4F_dctx, decltype(&LZ4F_freeDecompressionContext)> ctx(raw, LZ4F_freeDecompressionContext);
  Bytes out;
  std::size_t in_at = 0;
  std::size_t out_at = 0;
  while (true) {
    make_room(out, out_at, declared);
    std::size_t in_n = n - in_at;
    std::size_t out_n = out.size() - out_at;
    const auto hint = LZ4F_decompress(ctx.get(), out.data() + out_at, &out_n, in + in_at, &in_n, nullptr);
    if (LZ4F_isError(hint)) throw FormatError(fmt::format("{}: lz4: {}", where, LZ4F_getErrorName(hint)));
    in_at += in_n;
    out_at += out_n;
    if (hint == 0) break;  // the frame is complete
    if (in_n == 0 && out_n == 0) stuck(where, "lz4", declared);
  }
  check_whole(out_at, declared, in_at, n, where, "lz4");
  return out;
}

Bytes decompress_zstd(const std::uint8_t* in, std::size_t n, std::size_t declared, const std::string& where) {
  const std::unique_ptr<ZSTD_DCtx, decltype(&ZSTD_freeDCtx)> ctx(ZSTD_createDCtx(), ZSTD_freeDCtx);
  if (!ctx) throw std::bad_alloc();
  Bytes out;
  ZSTD_inBuffer input{in, n, 0};
  std::size_t out_at = 0;
  while (true) {
    make_room(out, out_at, declared);
    ZSTD_outBuffer output{out.data(), out.size(), out_at};
    const auto in_before = input.pos;
    const auto left = ZSTD_decompressStream(ctx.get(), &output, &input);
    if (ZSTD_isError(left)) throw FormatError(fmt::format("{}: zstd: {}", where, ZSTD_getErrorName(left)));
    const bool progressed = output.pos != out_at || input.pos != in_before;
    out_at = output.pos;
    if (left == 0 && input.pos == n) break;  // the last frame is complete and every byte taken
    if (!progressed) stuck(where, "zstd", declared);
  }
  check_whole(out_at, declared, input.pos, n, where, "zstd");
  return out;
}

}  // namespace

void compress(Compression c, const Bytes& in, Bytes& out) {
  switch (c) {
    case Compression::lz4: return compress_lz4(in, out);
    case Compression::zstd: return compress_zstd(in, out);
    case Compression::none: return put_raw(out, in.data(), in.size());
  }
}

Bytes decompress(Compression c, const std::uint8_t* in, std::size_t n, std::uint64_t uncompressed_size,
                 const std::string& where) {
  // A chunk declares its size; a hostile one must not make the reader allocate without bound.
  constexpr std::uint64_t kMaxChunkBytes = std::uint64_t{256} << 20;
  if (uncompressed_size > kMaxChunkBytes) {
    throw FormatError(fmt::format("{}: declares {} uncompressed bytes, more than this reader's limit of {}", where,
                                  uncompressed_size, kMaxChunkBytes));
  }
  if (c == Compression::none) {
    if (n != uncompressed_size) {
      throw FormatError(fmt::format("{}: holds {} bytes uncompressed, declares {}", where, n, uncompressed_size));
    }
    return Bytes(in, in + n);
  }
  return c == Compression::lz4 ? decompress_lz4(in, n, uncompressed_size, where)
                                : decompress_zstd(in, n, uncompressed_size, where);
}

}  // namespace rtm::mcap::detail
