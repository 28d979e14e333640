// SPDX-License-Identifier: Apache-2.0
// Files that are cut short, damaged or hostile: the indexed reader refuses them with a clear
// error, recovery keeps everything before the damage, and nothing crashes or allocates without
// bound.
#include <gtest/gtest.h>

#include <cstring>
#include <random>

#include "mcap_test_support.h"

namespace rtm::mcap::test {
namespace {

void write_bytes(const std::string& path, const std::vector<std::uint8_t>& bytes, std::size_t n) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(n));
}

std::string error_of(const std::string& path) {
  try {
    Reader r(path);
    r.messages();
  } catch (const FormatError& e) {
    return e.what();
  }
  return "";
}

// The messages in the chunks that end at or before byte `cut`, in file order.
std::uint64_t messages_in_whole_chunks(const Reader& whole, std::uint64_t cut) {
  std::uint64_t n = 0;
  for (const auto& ci : whole.chunk_indexes()) {
    if (ci.chunk_start_offset + ci.chunk_length > cut) break;
    n += whole.messages({ci.message_start_time, ci.message_end_time}).size();
  }
  return n;
}

TEST(McapRecovery, AFileCutAtAnyByteGivesEveryMessageOfItsWholeChunks) {
  TempDir dir;
  const auto path = dir.file("run.mcap");
  WriterOptions options;
  options.chunk_size = 1024;
  const auto written = write_sample(path, options, 400);
  const auto bytes = file_bytes(path);
  const Reader whole(path);
  ASSERT_GT(whole.chunk_indexes().size(), 5u);

  std::mt19937 random(7);
  std::vector<std::size_t> cuts{16, 40, bytes.size() - 1, bytes.size() - 8};
  for (int i = 0; i < 60; ++i) cuts.push_back(std::uniform_int_distribution<std::size_t>(17, bytes.size() - 2)(random));
  for (const auto& ci : whole.chunk_indexes()) {  // at a chunk's edges
    cuts.push_back(ci.chunk_start_offset);
    cuts.push_back(ci.chunk_start_offset + ci.chunk_length);
    cuts.push_back(ci.chunk_start_offset + ci.chunk_length - 1);
  }
  const auto cut_path = dir.file("cut.mcap");
  for (const auto cut : cuts) {
    write_bytes(cut_path, bytes, cut);
    EXPECT_NE(error_of(cut_path), "") << "cut at " << cut << " was read as whole";
    std::vector<Message> got;
    const auto found = recover(cut_path, [&](const Message& m) { got.push_back(m); });
    ASSERT_EQ(got.size(), messages_in_whole_chunks(whole, cut)) << "cut at " << cut << ": " << found.stopped_because;
    if (found.complete) {  // cut in the summary, after the data end: nothing was lost
      EXPECT_EQ(got.size(), written.size()) << "cut at " << cut;
    } else {
      EXPECT_NE(found.stopped_because, "") << "cut at " << cut;
    }
    EXPECT_LE(found.good_bytes, cut);
    for (std::size_t i = 0; i < got.size(); ++i) ASSERT_EQ(got[i].data, written[i].data) << "cut " << cut;
    if (!got.empty()) {
      EXPECT_EQ(found.channels.size(), 3u) << "cut at " << cut;
    }
  }
}

TEST(McapRecovery, AWholeFileIsReadToItsEnd) {
  TempDir dir;
  const auto path = dir.file("run.mcap");
  const auto written = write_sample(path, {}, 100);
  std::uint64_t n = 0;
  const auto found = recover(path, [&](const Message&) { ++n; });
  EXPECT_TRUE(found.complete) << found.stopped_because;
  EXPECT_EQ(n, written.size());
  EXPECT_EQ(found.metadata.size(), 1u);
}

TEST(McapRecovery, ARecoveredFileIsWholeAgainWithTheSameMessages) {
  TempDir dir;
  const auto path = dir.file("run.mcap");
  WriterOptions options;
  options.chunk_size = 1024;
  const auto written = write_sample(path, options, 400);
  const auto bytes = file_bytes(path);
  write_bytes(dir.file("cut.mcap"), bytes, bytes.size() * 2 / 3);
  const Reader whole(path);
  const auto expected = messages_in_whole_chunks(whole, bytes.size() * 2 / 3);

  const auto found = recover_to(dir.file("cut.mcap"), dir.file("fixed.mcap"));
  EXPECT_EQ(found.message_count, expected);
  Reader fixed(dir.file("fixed.mcap"));
  const auto got = fixed.messages();
  ASSERT_EQ(got.size(), expected);
  for (std::size_t i = 0; i < got.size(); ++i) EXPECT_EQ(got[i].data, written[i].data);
  EXPECT_EQ(fixed.channels().size(), 3u);
  EXPECT_EQ(fixed.schemas().size(), 1u);
  EXPECT_EQ(fixed.metadata().size(), 1u);
}

TEST(McapDamage, AFlippedByteInAChunkIsNamedAndRecoveryKeepsTheChunksBeforeIt) {
  for (const auto compression : {Compression::none, Compression::lz4, Compression::zstd}) {
    TempDir dir;
    const auto path = dir.file("run.mcap");
    WriterOptions options;
    options.chunk_size = 1024;
    options.compression = compression;
    write_sample(path, options, 300);
    const Reader whole(path);
    const auto& third = whole.chunk_indexes().at(2);
    auto bytes = file_bytes(path);
    bytes[third.chunk_start_offset + third.chunk_length - 20] ^= 0x5A;  // inside its records
    write_bytes(dir.file("bad.mcap"), bytes, bytes.size());

    const auto error = error_of(dir.file("bad.mcap"));
    EXPECT_NE(error.find(std::to_string(third.chunk_start_offset)), std::string::npos) << error;
    std::uint64_t n = 0;
    const auto found = recover(dir.file("bad.mcap"), [&](const Message&) { ++n; });
    EXPECT_EQ(n, messages_in_whole_chunks(whole, third.chunk_start_offset)) << compression_name(compression);
    EXPECT_NE(found.stopped_because.find("chunk"), std::string::npos) << found.stopped_because;
  }
}

TEST(McapDamage, NotAnMcapFileIsSaidSo) {
  TempDir dir;
  const auto path = dir.file("text.mcap");
  write_bytes(path, std::vector<std::uint8_t>(100, 'x'), 100);
  EXPECT_NE(error_of(path).find("not an MCAP file"), std::string::npos) << error_of(path);
  EXPECT_THROW(recover(path, [](const Message&) {}), FormatError);
  write_bytes(path, {}, 0);
  EXPECT_NE(error_of(path).find("too short"), std::string::npos) << error_of(path);
  EXPECT_THROW(Reader(dir.file("missing.mcap")), std::system_error);
}

TEST(McapDamage, ASummaryThatDoesNotMatchItsCrcIsRefused) {
  TempDir dir;
  const auto path = dir.file("run.mcap");
  write_sample(path, {}, 10);
  auto bytes = file_bytes(path);
  std::uint64_t summary_start = 0;
  std::memcpy(&summary_start, bytes.data() + bytes.size() - 8 - 29 + 9, sizeof summary_start);
  bytes[summary_start + 20] ^= 1;
  write_bytes(path, bytes, bytes.size());
  EXPECT_NE(error_of(path).find("CRC"), std::string::npos) << error_of(path);
}

// A record that claims more than the file holds, a chunk that claims gigabytes: errors, not
// crashes or allocations of what the file says.
TEST(McapDamage, LengthsThatLieAreErrorsNotAllocations) {
  TempDir dir;
  const auto path = dir.file("run.mcap");
  WriterOptions options;
  options.compression = Compression::zstd;
  write_sample(path, options, 50);
  const Reader whole(path);
  const auto& ci = whole.chunk_indexes().at(0);
  const auto pristine = file_bytes(path);

  auto bytes = pristine;  // the chunk's record length
  const std::uint64_t huge = std::uint64_t{1} << 62;
  std::memcpy(bytes.data() + ci.chunk_start_offset + 1, &huge, sizeof huge);
  write_bytes(path, bytes, bytes.size());
  EXPECT_NE(error_of(path), "");
  auto found = recover(path, [](const Message&) {});
  EXPECT_NE(found.stopped_because.find("cut short"), std::string::npos) << found.stopped_because;

  bytes = pristine;  // the chunk's uncompressed size
  std::memcpy(bytes.data() + ci.chunk_start_offset + 9 + 16, &huge, sizeof huge);
  write_bytes(path, bytes, bytes.size());
  EXPECT_NE(error_of(path).find("limit"), std::string::npos) << error_of(path);

  // Under the limit but a lie: the frame holds far less. Decoding costs what the frame
  // holds (the output grows as it yields), and the lie is named.
  bytes = pristine;
  const std::uint64_t lie = std::uint64_t{200} << 20;
  std::memcpy(bytes.data() + ci.chunk_start_offset + 9 + 16, &lie, sizeof lie);
  write_bytes(path, bytes, bytes.size());
  EXPECT_NE(error_of(path).find("the chunk declares 209715200"), std::string::npos) << error_of(path);

  bytes = pristine;  // a string's length inside the header
  const std::uint32_t long_string = 0xFFFFFFF0u;
  std::memcpy(bytes.data() + 8 + 9, &long_string, sizeof long_string);
  write_bytes(path, bytes, bytes.size());
  EXPECT_NE(error_of(path).find("header profile"), std::string::npos) << error_of(path);
}

}  // namespace
}  // namespace rtm::mcap::test
