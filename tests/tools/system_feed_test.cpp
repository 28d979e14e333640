// SPDX-License-Identifier: Apache-2.0
// rtm serve's system feed: one poll per period for every page together, a fresh view for a page
// that comes after an idle spell, and a stop that wakes the pages waiting.
#include "serve/system_feed.h"


#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <string>
#include <thread>
#include <vector>

namespace {

using rtm::cli::SystemFeed;
using namespace std::chrono_literals;

TEST(SystemFeed, WithNoPageConnectedNothingIsPolled) {
  std::atomic<int> calls{0};
  SystemFeed feed([&] { return std::to_string(calls++); }, 20ms);
  std::this_thread::sleep_for(200ms);
  EXPECT_EQ(feed.polls(), 0u);
  SystemFeed::Subscription page(feed);
  const auto first = page.next(10s);
  ASSERT_TRUE(first.has_value());
  EXPECT_EQ(first->text, "0");
}

// The components' timing differs on every look: a stream that sent whenever the answer changed
// polled without pause. Three pages for a second: at most one poll per period in all.
TEST(SystemFeed, ASystemThatChangesOnEveryLookIsPolledOncePerPeriodForAllPagesTogether) {
  std::atomic<int> calls{0};
  constexpr auto period = 100ms;
  SystemFeed feed([&] { return std::to_string(calls++); }, period);
  std::vector<int> received(3, 0);
  std::vector<std::thread> pages;
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < 3; ++i)
    pages.emplace_back([&, i] {
      SystemFeed::Subscription page(feed);
      while (std::chrono::steady_clock::now() - start < 1s)
        if (page.next(200ms)) ++received[i];
    });
  for (auto& t : pages) t.join();
  const auto elapsed = std::chrono::steady_clock::now() - start;
  const auto allowed = static_cast<std::uint64_t>(elapsed / period) + 2;
  EXPECT_LE(feed.polls(), allowed) << "in " << std::chrono::duration<double>(elapsed).count() << " s";
  for (int i = 0; i < 3; ++i) EXPECT_GE(received[i], 2) << "page " << i << " was not fed";
}

TEST(SystemFeed, APageJoiningOthersGetsTheLatestViewAtOnce) {
  SystemFeed feed([] { return std::string("view"); }, 60s);
  SystemFeed::Subscription first(feed);
  ASSERT_TRUE(first.next(10s).has_value());
  SystemFeed::Subscription second(feed);
  const auto got = second.next(0ms);
  ASSERT_TRUE(got.has_value()) << "the page that joined waited for the next poll, a minute away";
  EXPECT_EQ(got->text, "view");
  EXPECT_EQ(feed.polls(), 1u);
}

// After every page left, the feed stops polling: its last view may be old. A page that comes
// then gets one polled after it came, even when that one reads the same.
TEST(SystemFeed, APageThatComesAfterAnIdleSpellGetsAFreshPollNotTheViewLeftFromBefore) {
  SystemFeed feed([] { return std::string("unchanged"); }, 50ms);
  {
    SystemFeed::Subscription page(feed);
    ASSERT_TRUE(page.next(10s).has_value());
  }
  std::this_thread::sleep_for(200ms);
  const auto before = feed.polls();
  SystemFeed::Subscription later(feed);
  const auto got = later.next(10s);
  ASSERT_TRUE(got.has_value()) << "the page that came later got nothing: the view read the same";
  EXPECT_GT(feed.polls(), before) << "it was given the view left from before";
}

TEST(SystemFeed, StopWakesAWaitingPageWithNothing) {
  SystemFeed feed([] { return std::string("still"); }, 10ms);
  SystemFeed::Subscription page(feed);
  ASSERT_TRUE(page.next(10s).has_value());
  std::optional<SystemFeed::Update> got{SystemFeed::Update{"not woken"}};
  auto waited = std::chrono::steady_clock::duration{};
  std::thread waiting([&] {
    const auto t0 = std::chrono::steady_clock::now();
    got = page.next(60s);
    waited = std::chrono::steady_clock::now() - t0;
  });
  std::this_thread::sleep_for(100ms);
  feed.stop();
  waiting.join();
  EXPECT_FALSE(got.has_value());
  EXPECT_TRUE(feed.stopped());
  EXPECT_LT(waited, 60s) << "stop did not wake the waiting page: it waited out its timeout";
}

}  // namespace

