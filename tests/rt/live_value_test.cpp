// SPDX-License-Identifier: Apache-2.0
// LiveValue: a parameter published by one thread reaches the cycle whole and newest.
#include "rt/live_value.h"

#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <thread>

namespace {

TEST(LiveValue, TakeReportsNothingNewUntilSomethingIsPublished) {
  rtm::LiveValue<int> value{7};
  int out = -1;
  EXPECT_FALSE(value.take(out));
  EXPECT_EQ(out, -1);  // left alone
  EXPECT_EQ(value.published(), 7);
}

TEST(LiveValue, TheNewestOfSeveralPublishedValuesIsTakenOnce) {
  rtm::LiveValue<int> value{0};
  value.publish(1);
  value.publish(2);
  value.publish(3);
  int out = 0;
  ASSERT_TRUE(value.take(out));
  EXPECT_EQ(out, 3);
  EXPECT_FALSE(value.take(out));
  EXPECT_EQ(value.published(), 3);
  value.publish(4);
  ASSERT_TRUE(value.take(out));
  EXPECT_EQ(out, 4);
}

// Every published array holds one number six times: a reader that ever sees two different
// numbers in one array has seen a torn value.
TEST(LiveValue, AReaderRacingAWriterNeverSeesATornOrOlderValue) {
  rtm::LiveValue<std::array<std::uint64_t, 6>> value{{}};
  constexpr std::uint64_t kLast = 200'000;
  std::atomic<bool> done{false};
  std::thread writer([&] {
    for (std::uint64_t i = 1; i <= kLast; ++i) value.publish({i, i, i, i, i, i});
    done = true;
  });
  std::uint64_t torn = 0, backwards = 0, newest = 0, takes = 0;
  std::array<std::uint64_t, 6> out{};
  auto check = [&] {
    for (auto v : out) torn += v != out[0];
    backwards += out[0] < newest;
    newest = out[0];
    ++takes;
  };
  while (!done.load()) {
    if (value.take(out)) check();
  }
  writer.join();
  if (value.take(out)) check();
  EXPECT_EQ(torn, 0u);
  EXPECT_EQ(backwards, 0u);
  EXPECT_EQ(newest, kLast);
  EXPECT_GT(takes, 0u);
}

}  // namespace
