// SPDX-License-Identifier: Apache-2.0
// Handing a periodic grid from one activity to another: stop one after deadline d, start the
// other at d. What the CAN master and the servo's shared tick do with the SYNC cycles.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <thread>
#include <vector>

#include "rt/activity.h"
#include "rt/clock.h"
#include "rtm_test/eventually.h"

namespace {

constexpr std::int64_t kPeriod_ns = 2'000'000;

struct DeadlineLog {
  std::mutex mu;
  std::vector<std::int64_t> deadlines;
  rtm::CycleFunction recorder() {
    return [this](const rtm::CycleContext& ctx) {
      std::lock_guard lock(mu);
      deadlines.push_back(ctx.deadline_ns);
      return true;
    };
  }
  std::size_t size() {
    std::lock_guard lock(mu);
    return deadlines.size();
  }
};

void wait_for_cycles(DeadlineLog& log, std::size_t n) {
  rtm_test::eventually([&] { return log.size() >= n; });
}

TEST(PeriodicHandover, NextDeadlineIsKnownAsSoonAsStartReturns) {
  DeadlineLog log;
  rtm::PeriodicOptions options;
  options.period_ns = kPeriod_ns;
  EXPECT_EQ(rtm::PeriodicActivity(log.recorder(), options).next_deadline_ns(), 0) << "never started";
  options.first_deadline_ns = rtm::monotonic_ns() + 50 * kPeriod_ns;
  rtm::PeriodicActivity activity(log.recorder(), options);
  activity.start();
  EXPECT_EQ(activity.next_deadline_ns(), options.first_deadline_ns);
  activity.stop();
  EXPECT_EQ(activity.next_deadline_ns(), options.first_deadline_ns) << "stopped before it: not run, still next";
  EXPECT_EQ(log.size(), 0u);
}

TEST(PeriodicHandover, TheOtherActivityStartedAtTheStoppedOnesNextDeadlineLosesAndDoublesNoCycle) {
  // 20 ms: a host stall of a few ms cannot push the hand-over past the deadline handed over.
  constexpr std::int64_t kSlow_ns = 20'000'000;
  DeadlineLog a_log, b_log;
  rtm::PeriodicOptions options;
  options.period_ns = kSlow_ns;
  rtm::PeriodicActivity a(a_log.recorder(), options);
  rtm::PeriodicActivity b(b_log.recorder(), options);
  a.start();
  wait_for_cycles(a_log, 3);
  const std::int64_t d = a.stop_after_cycle();
  EXPECT_FALSE(a.running());
  EXPECT_EQ(a.next_deadline_ns(), d);
  ASSERT_FALSE(a_log.deadlines.empty());
  const std::int64_t a_last = a_log.deadlines.back();
  EXPECT_EQ(d - a_last, kSlow_ns) << "the stopped activity ran every deadline before the one handed over";

  b.set_first_deadline_ns(d);
  b.start();
  wait_for_cycles(b_log, 3);
  b.stop();
  ASSERT_FALSE(b_log.deadlines.empty());
  EXPECT_EQ(b_log.deadlines.front(), d) << "the other activity's first cycle is the one handed over";
  for (std::size_t i = 1; i < b_log.deadlines.size(); ++i)
    EXPECT_EQ((b_log.deadlines[i] - d) % kSlow_ns, 0) << "cycle " << i << " left the grid";
}

TEST(PeriodicHandover, AStartAtADeadlineAlreadyPastJoinsTheGridWithoutABurst) {
  DeadlineLog log;
  rtm::PeriodicOptions options;
  options.period_ns = kPeriod_ns;
  const std::int64_t origin = rtm::monotonic_ns() - 10 * kPeriod_ns - 300'000;
  options.first_deadline_ns = origin;
  rtm::PeriodicActivity activity(log.recorder(), options);
  const std::int64_t before = rtm::monotonic_ns();
  activity.start();
  EXPECT_GE(activity.next_deadline_ns(), before) << "a past deadline moves forward";
  EXPECT_EQ((activity.next_deadline_ns() - origin) % kPeriod_ns, 0) << "keeping the phase handed over";
  wait_for_cycles(log, 2);
  activity.stop();
  EXPECT_GE(log.deadlines.front(), before) << "the ten missed deadlines are not run";
}

}  // namespace
