// SPDX-License-Identifier: Apache-2.0
// The shared ring in one process (threads stand in for processes; shm_segment_test.cpp runs
// it across processes): what a reader gets, in which order, what it misses, and that a datum
// it keeps is never torn.
#include "rt/shm_ring.h"

#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <cstring>
#include <ctime>
#include <memory>
#include <stdexcept>
#include <thread>
#include <vector>

namespace {

using rtm::ReadStatus;
using rtm::ShmRingReader;
using rtm::ShmRingShape;
using rtm::ShmRingWriter;

constexpr std::uint64_t kType = 0x5EED;

// Zeroed, 64-byte aligned memory for a ring, as a fresh mapping would be.
struct Memory {
  explicit Memory(const ShmRingShape& shape) : bytes(rtm::shm_ring_bytes(shape)) {
    data.reset(static_cast<std::byte*>(::operator new(bytes, std::align_val_t{64})));
    std::memset(data.get(), 0, bytes);
  }
  struct Free {
    void operator()(std::byte* p) const { ::operator delete(p, std::align_val_t{64}); }
  };
  std::size_t bytes;
  std::unique_ptr<std::byte, Free> data;
};

std::span<const std::byte> bytes_of(const auto& value) { return std::as_bytes(std::span(&value, 1)); }

std::int64_t now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return std::int64_t{ts.tv_sec} * 1'000'000'000 + ts.tv_nsec;
}

TEST(ShmRing, NothingIsReadBeforeTheFirstWrite) {
  const ShmRingShape shape{4, 16, kType};
  Memory m(shape);
  ShmRingWriter writer(m.data.get(), m.bytes, shape);
  ShmRingReader reader(m.data.get(), m.bytes, kType);
  std::array<std::byte, 16> buf{};
  EXPECT_EQ(reader.take_latest(buf).status, ReadStatus::no_data);
  EXPECT_EQ(reader.take_next(buf).status, ReadStatus::no_data);
  EXPECT_EQ(reader.published(), 0U);
  EXPECT_FALSE(reader.write_in_progress());
}

TEST(ShmRing, TakeLatestGivesTheNewestDatumAsNewThenAsOld) {
  const ShmRingShape shape{4, 16, kType};
  Memory m(shape);
  ShmRingWriter writer(m.data.get(), m.bytes, shape);
  ShmRingReader reader(m.data.get(), m.bytes, kType);
  for (double v : {1.5, 2.5, 3.5}) writer.write(bytes_of(v));
  double out = 0;
  const auto first = reader.take_latest(std::as_writable_bytes(std::span(&out, 1)));
  EXPECT_EQ(first.status, ReadStatus::new_data);
  EXPECT_EQ(first.size, sizeof(double));
  EXPECT_EQ(first.number, 3U);
  EXPECT_EQ(out, 3.5);
  out = 0;
  const auto again = reader.take_latest(std::as_writable_bytes(std::span(&out, 1)));
  EXPECT_EQ(again.status, ReadStatus::old_data);
  EXPECT_EQ(out, 3.5);
}

TEST(ShmRing, TakeNextGivesOnlyDataWrittenAfterTheReaderCameInOrder) {
  const ShmRingShape shape{8, 8, kType};
  Memory m(shape);
  ShmRingWriter writer(m.data.get(), m.bytes, shape);
  for (std::uint64_t v = 100; v < 103; ++v) writer.write(bytes_of(v));  // before the reader
  ShmRingReader reader(m.data.get(), m.bytes, kType);
  for (std::uint64_t v = 1; v <= 5; ++v) writer.write(bytes_of(v));
  std::uint64_t out = 0;
  for (std::uint64_t want = 1; want <= 5; ++want) {
    const auto r = reader.take_next(std::as_writable_bytes(std::span(&out, 1)));
    ASSERT_EQ(r.status, ReadStatus::new_data);
    EXPECT_EQ(out, want);
    EXPECT_EQ(r.missed, 0U);
  }
  EXPECT_EQ(reader.take_next(std::as_writable_bytes(std::span(&out, 1))).status, ReadStatus::no_data);
}

TEST(ShmRing, AReaderMoreThanARingBehindIsToldHowManyItMissed) {
  const ShmRingShape shape{4, 8, kType};
  Memory m(shape);
  ShmRingWriter writer(m.data.get(), m.bytes, shape);
  ShmRingReader reader(m.data.get(), m.bytes, kType);
  for (std::uint64_t v = 1; v <= 20; ++v) writer.write(bytes_of(v));
  std::uint64_t out = 0, missed = 0;
  std::vector<std::uint64_t> got;
  for (;;) {
    const auto r = reader.take_next(std::as_writable_bytes(std::span(&out, 1)));
    missed += r.missed;
    if (r.status == ReadStatus::no_data) break;
    EXPECT_EQ(out, r.number);
    got.push_back(out);
  }
  // The slot the writer would fill next is never read: 4 slots keep the newest 3 readable.
  EXPECT_EQ(got, (std::vector<std::uint64_t>{18, 19, 20}));
  EXPECT_EQ(missed, 17U);
}

// A reader that keeps at most `keep` data skips all but the newest `keep` of what it knows is
// there: has_new() looks at the writer's head (once caught up) and skip_older() only uses the
// head seen last, so a backlog taken datum by datum reads the writer's head line once.
TEST(ShmRing, HasNewSeesANewDatumAndSkipOlderKeepsTheNewestOfTheHeadSeenLast) {
  const ShmRingShape shape{16, 8, kType};
  Memory m(shape);
  ShmRingWriter writer(m.data.get(), m.bytes, shape);
  ShmRingReader reader(m.data.get(), m.bytes, kType);
  EXPECT_FALSE(reader.has_new());
  for (std::uint64_t v = 1; v <= 10; ++v) writer.write(bytes_of(v));
  EXPECT_EQ(reader.skip_older(3), 0U) << "no head seen since the writes: nothing is known to skip";
  ASSERT_TRUE(reader.has_new());
  EXPECT_EQ(reader.skip_older(3), 7U);
  writer.write(bytes_of(std::uint64_t{11}));  // after the head was seen: taken too, at the end
  std::uint64_t out = 0;
  std::vector<std::uint64_t> got;
  while (reader.has_new()) {
    const auto r = reader.take_next(std::as_writable_bytes(std::span(&out, 1)));
    ASSERT_EQ(r.status, ReadStatus::new_data);
    EXPECT_EQ(r.missed, 0U);
    got.push_back(out);
  }
  EXPECT_EQ(got, (std::vector<std::uint64_t>{8, 9, 10, 11}));
  EXPECT_EQ(reader.skip_older(0), 0U) << "caught up: nothing left to skip";
}

TEST(ShmRing, DataOfAnySizeUpToTheSlotComeBackExactly) {
  const ShmRingShape shape{2, 13, kType};
  Memory m(shape);
  ShmRingWriter writer(m.data.get(), m.bytes, shape);
  ShmRingReader reader(m.data.get(), m.bytes, kType);
  for (std::size_t size : {1U, 7U, 8U, 9U, 13U}) {
    std::array<std::byte, 13> in{}, out{};
    for (std::size_t i = 0; i < size; ++i) in[i] = static_cast<std::byte>(0xA0 + i + size);
    writer.write(std::span(in.data(), size));
    const auto r = reader.take_next(out);
    ASSERT_EQ(r.status, ReadStatus::new_data);
    ASSERT_EQ(r.size, size);
    EXPECT_EQ(std::memcmp(in.data(), out.data(), size), 0) << size << " bytes";
  }
}

TEST(ShmRing, ADatumLargerThanASlotIsRefusedAndNothingIsPublished) {
  const ShmRingShape shape{4, 8, kType};
  Memory m(shape);
  ShmRingWriter writer(m.data.get(), m.bytes, shape);
  ShmRingReader reader(m.data.get(), m.bytes, kType);
  std::array<std::byte, 9> big{};
  EXPECT_THROW(writer.write(big), std::length_error);
  EXPECT_EQ(writer.written(), 0U);
  EXPECT_EQ(reader.published(), 0U);
}

TEST(ShmRing, BadShapesAreRefusedByTheWriter) {
  Memory m(ShmRingShape{4, 64, kType});
  EXPECT_THROW(ShmRingWriter(m.data.get(), m.bytes, {1, 8, kType}), std::invalid_argument);
  EXPECT_THROW(ShmRingWriter(m.data.get(), m.bytes, {4, 0, kType}), std::invalid_argument);
  EXPECT_THROW(ShmRingWriter(m.data.get(), m.bytes - 1, {4, 64, kType}), std::invalid_argument);
  EXPECT_THROW(ShmRingWriter(m.data.get() + 8, m.bytes - 64, {2, 8, kType}), std::invalid_argument);
}

TEST(ShmRing, AReaderRefusesAnotherTypeMemoryWithoutARingAndALayoutLargerThanTheMemory) {
  const ShmRingShape shape{4, 16, kType};
  Memory m(shape);
  EXPECT_THROW(ShmRingReader(m.data.get(), m.bytes, kType), std::runtime_error);  // all zero: no ring
  ShmRingWriter writer(m.data.get(), m.bytes, shape);
  try {
    ShmRingReader(m.data.get(), m.bytes, kType + 1);
    FAIL() << "a reader of another type was made";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("another data type"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ShmRingReader(m.data.get(), m.bytes - 64, kType), std::runtime_error);
  EXPECT_NO_THROW(ShmRingReader(m.data.get(), m.bytes, kType));
}

TEST(ShmRing, AReaderWaitingForDataIsWokenByEachWrite) {
  // Ping-pong between two threads over two rings: each wait must end by a write, not by its
  // deadline (wait_for_data returns false when the deadline ended it).
  const ShmRingShape shape{4, 8, kType};
  Memory ping_m(shape), pong_m(shape);
  ShmRingWriter ping(ping_m.data.get(), ping_m.bytes, shape);
  ShmRingWriter pong(pong_m.data.get(), pong_m.bytes, shape);
  ShmRingReader ping_reader(ping_m.data.get(), ping_m.bytes, kType);
  ShmRingReader pong_reader(pong_m.data.get(), pong_m.bytes, kType);
  constexpr std::uint64_t kRounds = 2000;
  std::atomic<std::uint64_t> echo_failures{0};
  std::thread echo([&] {
    std::uint64_t v = 0;
    for (std::uint64_t i = 0; i < kRounds; ++i) {
      if (!ping_reader.wait_for_data(ShmRingReader::kNoDeadline)) ++echo_failures;  // no timer
      const auto r = ping_reader.take_next(std::as_writable_bytes(std::span(&v, 1)));
      if (r.status != ReadStatus::new_data || v != i) ++echo_failures;
      pong.write(bytes_of(v));
    }
  });
  std::uint64_t failures = 0, v = 0;
  for (std::uint64_t i = 0; i < kRounds; ++i) {
    ping.write(bytes_of(i));
    if (!pong_reader.wait_for_data(now_ns() + 30'000'000'000)) ++failures;
    const auto r = pong_reader.take_next(std::as_writable_bytes(std::span(&v, 1)));
    if (r.status != ReadStatus::new_data || v != i) ++failures;
  }
  echo.join();
  EXPECT_EQ(failures, 0U);
  EXPECT_EQ(echo_failures.load(), 0U);
}

TEST(ShmRing, AWaitWithNoWriteEndsAtItsDeadlineWithFalse) {
  const ShmRingShape shape{4, 8, kType};
  Memory m(shape);
  ShmRingWriter writer(m.data.get(), m.bytes, shape);
  ShmRingReader reader(m.data.get(), m.bytes, kType);
  EXPECT_FALSE(reader.wait_for_data(now_ns() + 2'000'000));
  EXPECT_FALSE(reader.wait_for_data(now_ns() - 1));  // a deadline already past
  const std::uint64_t v = 7;
  writer.write(bytes_of(v));
  EXPECT_TRUE(reader.wait_for_data(now_ns() - 1));  // data there: no wait at all
}

// Every datum is 64 words all equal to its number: a reader that kept a mix of two data would
// see different words.
struct Pattern {
  std::array<std::uint64_t, 64> words;
};

bool whole(const Pattern& p, std::uint64_t number) {
  for (const auto w : p.words)
    if (w != number) return false;
  return true;
}

TEST(ShmRing, ReadersRacingAWriterThatLapsTheRingNeverKeepATornDatum) {
  const ShmRingShape shape{2, sizeof(Pattern), kType};  // 2 slots: every read races a write
  Memory m(shape);
  ShmRingWriter writer(m.data.get(), m.bytes, shape);
  std::atomic<bool> stop{false};
  std::atomic<std::uint64_t> torn{0}, kept{0}, out_of_order{0};
  auto read = [&](ShmRingReader& reader, bool fifo) {
    Pattern p{};
    std::uint64_t last = 0;
    while (!stop.load(std::memory_order_relaxed)) {
      const auto r = fifo ? reader.take_next(std::as_writable_bytes(std::span(&p, 1)))
                          : reader.take_latest(std::as_writable_bytes(std::span(&p, 1)));
      if (r.status == ReadStatus::no_data) continue;
      if (!whole(p, r.number)) ++torn;
      if (r.status == ReadStatus::new_data && r.number <= last) ++out_of_order;
      last = r.number;
      ++kept;
    }
  };
  std::atomic<int> started{0};
  auto start_then_read = [&](bool fifo) {
    ShmRingReader reader(m.data.get(), m.bytes, kType);
    ++started;
    read(reader, fifo);
  };
  std::thread latest(start_then_read, false), fifo(start_then_read, true);
  while (started.load() < 2) std::this_thread::yield();
  Pattern p{};
  for (std::uint64_t n = 1; n <= 200'000; ++n) {
    p.words.fill(n);
    writer.write(bytes_of(p));
  }
  stop = true;
  latest.join();
  fifo.join();
  EXPECT_EQ(torn.load(), 0U);
  EXPECT_EQ(out_of_order.load(), 0U);
  EXPECT_GT(kept.load(), 0U);
}

}  // namespace
