// SPDX-License-Identifier: Apache-2.0
// The writer and the indexed reader, each checked against the other and against the bytes the
// specification fixes. (tests/mcap/reference checks both against the format's own readers.)
#include <gtest/gtest.h>

#include <cstring>

#include "mcap_test_support.h"

namespace rtm::mcap::test {
namespace {

void expect_same(const std::vector<Message>& got, const std::vector<Message>& want) {
  ASSERT_EQ(got.size(), want.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].channel_id, want[i].channel_id) << "message " << i;
    EXPECT_EQ(got[i].sequence, want[i].sequence) << "message " << i;
    EXPECT_EQ(got[i].log_time, want[i].log_time) << "message " << i;
    EXPECT_EQ(got[i].publish_time, want[i].publish_time) << "message " << i;
    EXPECT_EQ(got[i].data, want[i].data) << "message " << i;
  }
}

class EachCompression : public ::testing::TestWithParam<Compression> {};

TEST_P(EachCompression, WhatIsWrittenIsReadBackWithItsSummary) {
  TempDir dir;
  const auto path = dir.file("run.mcap");
  WriterOptions options;
  options.compression = GetParam();
  options.chunk_size = 4096;  // many chunks
  const auto written = write_sample(path, options, 5000);

  Reader r(path);
  EXPECT_EQ(r.header().library, "rtm");
  ASSERT_EQ(r.schemas().size(), 1u);
  EXPECT_EQ(r.schemas()[0].name, "RTM::TimedFloat6");
  EXPECT_EQ(r.schemas()[0].encoding, "omgidl");
  ASSERT_EQ(r.channels().size(), 3u);
  EXPECT_EQ(r.channel("port2")->metadata.at("units"), "N");
  EXPECT_EQ(r.statistics().message_count, 5000u);
  EXPECT_EQ(r.statistics().channel_message_counts.at(1), 1667u);
  EXPECT_EQ(r.statistics().message_start_time, written.front().log_time);
  EXPECT_EQ(r.statistics().message_end_time, written.back().log_time);
  EXPECT_GT(r.chunk_indexes().size(), 10u);
  EXPECT_EQ(r.statistics().chunk_count, r.chunk_indexes().size());
  for (const auto& ci : r.chunk_indexes()) EXPECT_EQ(ci.compression, compression_name(GetParam()));
  const auto metadata = r.metadata();
  ASSERT_EQ(metadata.size(), 1u);
  EXPECT_EQ(metadata[0].name, "system");
  EXPECT_EQ(metadata[0].values.at("components"), "sensor0 controller0");

  expect_same(r.messages(), written);
}

INSTANTIATE_TEST_SUITE_P(Mcap, EachCompression,
                         ::testing::Values(Compression::none, Compression::lz4, Compression::zstd),
                         [](const auto& info) { return std::string(info.param == Compression::none ? "none"
                                                                   : compression_name(info.param)); });

TEST(McapReader, ARangeGivesExactlyTheMessagesInItFromTheChunksThatHoldIt) {
  TempDir dir;
  const auto path = dir.file("run.mcap");
  WriterOptions options;
  options.chunk_size = 2048;
  const auto written = write_sample(path, options, 3000);
  Reader r(path);
  const ReadRange range{written[1000].log_time, written[1999].log_time};
  const auto got = r.messages(range);
  expect_same(got, std::vector<Message>(written.begin() + 1000, written.begin() + 2000));
}

TEST(McapReader, MessagesWrittenOutOfOrderAreGivenInLogTimeOrder) {
  TempDir dir;
  const auto path = dir.file("late.mcap");
  WriterOptions options;
  options.chunk_size = 512;
  std::vector<Message> written;
  {
    Writer w(path, options);
    const auto ch = w.add_channel(0, "late", "cdr");
    // Each datum arrives with a stamp up to 30 ms old: chunks overlap in time.
    for (std::uint32_t n = 0; n < 600; ++n) {
      const std::uint64_t t = 1'000'000'000ULL + n * 1'000'000ULL - (n % 5) * 30'000'000ULL / 4;
      auto m = sample_message(ch, n, t);
      w.write(m.channel_id, m.sequence, m.log_time, m.publish_time, m.data);
      written.push_back(std::move(m));
    }
  }
  std::stable_sort(written.begin(), written.end(),
                   [](const Message& a, const Message& b) { return a.log_time < b.log_time; });
  Reader r(path);
  expect_same(r.messages(), written);
}

TEST(McapWriter, TheFileStartsAndEndsWithTheMagicAndItsFooterPointsAtTheSummary) {
  TempDir dir;
  const auto path = dir.file("run.mcap");
  write_sample(path, {}, 10);
  const auto bytes = file_bytes(path);
  ASSERT_GT(bytes.size(), 2 * sizeof kMagic);
  EXPECT_EQ(std::memcmp(bytes.data(), kMagic, sizeof kMagic), 0);
  EXPECT_EQ(std::memcmp(bytes.data() + bytes.size() - sizeof kMagic, kMagic, sizeof kMagic), 0);
  EXPECT_EQ(bytes[sizeof kMagic], static_cast<std::uint8_t>(Opcode::header));
  const auto footer = bytes.size() - sizeof kMagic - 29;
  EXPECT_EQ(bytes[footer], static_cast<std::uint8_t>(Opcode::footer));
  std::uint64_t summary_start = 0;
  std::memcpy(&summary_start, bytes.data() + footer + 9, sizeof summary_start);
  ASSERT_LT(summary_start, footer);
  // The data end closes the data section, just before the summary.
  EXPECT_EQ(bytes[summary_start - 13], static_cast<std::uint8_t>(Opcode::data_end));
  EXPECT_EQ(bytes[summary_start], static_cast<std::uint8_t>(Opcode::schema));
}

TEST(McapWriter, AMessageOnAChannelNeverAddedIsRefused) {
  TempDir dir;
  Writer w(dir.file("x.mcap"));
  const std::uint8_t byte = 0;
  EXPECT_THROW(w.write(1, 0, 0, 0, {&byte, 1}), std::invalid_argument);
  EXPECT_THROW(w.add_channel(4, "t", "cdr"), std::invalid_argument);
}

TEST(McapWriter, AFolderThatCannotBeWrittenIsASystemErrorNamingThePath) {
  try {
    Writer w("/nonexistent-folder/run.mcap");
    FAIL() << "no error";
  } catch (const std::system_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent-folder/run.mcap"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace rtm::mcap::test
