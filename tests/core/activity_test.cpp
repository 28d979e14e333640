// SPDX-License-Identifier: Apache-2.0
#include "core_test_support.h"

#include "rt/activity.h"
#include "rtm/data.h"

#include <gtest/gtest.h>

#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

namespace {

using rtm::test::eventually;
using namespace std::chrono_literals;

rtm::PeriodicOptions fast(std::int64_t period_ns = 1'000'000) {
  rtm::PeriodicOptions o;
  o.period_ns = period_ns;
  o.thread_name = "test-periodic";
  return o;
}

TEST(PeriodicActivity, StartAndStopAreIdempotentAndRestartable) {
  std::atomic<long> cycles{0};
  rtm::PeriodicActivity activity([&](const rtm::CycleContext&) { return ++cycles, true; }, fast());
  EXPECT_FALSE(activity.running());
  activity.stop();  // stop before start: nothing happens
  for (int round = 0; round < 5; ++round) {
    activity.start();
    activity.start();
    EXPECT_TRUE(activity.running());
    const long before = cycles.load();
    ASSERT_TRUE(eventually([&] { return cycles.load() > before + 2; }));
    activity.stop();
    activity.stop();
    EXPECT_FALSE(activity.running());
  }
}

TEST(PeriodicActivity, StopReturnsOnlyAfterTheThreadEnded) {
  std::atomic<bool> inside{false};
  std::atomic<long> cycles{0};
  rtm::PeriodicActivity activity(
      [&](const rtm::CycleContext&) {
        inside = true;
        std::this_thread::sleep_for(std::chrono::milliseconds(3));  // stop() arrives mid-cycle
        ++cycles;
        inside = false;
        return true;
      },
      fast());
  activity.start();
  ASSERT_TRUE(eventually([&] { return inside.load(); }));
  activity.stop();
  EXPECT_FALSE(inside.load());
  const long after_stop = cycles.load();
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_EQ(cycles.load(), after_stop);
  EXPECT_EQ(activity.stats().cycles, static_cast<std::uint64_t>(after_stop));
}

TEST(PeriodicActivity, SlowCycleCountsOverrunAndSkipsOnTheOriginalGrid) {
  std::mutex mu;
  std::vector<std::int64_t> deadlines;
  rtm::PeriodicActivity activity(
      [&](const rtm::CycleContext& ctx) {
        {
          std::lock_guard lock(mu);
          deadlines.push_back(ctx.deadline_ns);
        }
        // Cycle 2 takes >= 5 periods: its next deadline is more than one period behind.
        if (ctx.cycle == 2) std::this_thread::sleep_for(std::chrono::milliseconds(5));
        return true;
      },
      fast(1'000'000));
  activity.start();
  ASSERT_TRUE(eventually([&] {
    std::lock_guard lock(mu);
    return deadlines.size() >= 10;
  }));
  activity.stop();
  const rtm::ActivityStats stats = activity.stats();
  EXPECT_GE(stats.overruns, 1u);
  EXPECT_GE(stats.skipped, 3u);
  std::lock_guard lock(mu);
  for (std::size_t i = 1; i < deadlines.size(); ++i) {
    EXPECT_EQ((deadlines[i] - deadlines[0]) % 1'000'000, 0) << "deadline " << i << " left the grid";
    EXPECT_GT(deadlines[i], deadlines[i - 1]);
  }
}

TEST(PeriodicActivity, ContextCountsCyclesAndCarriesThePeriod) {
  std::vector<rtm::CycleContext> seen;
  rtm::PeriodicActivity activity(
      [&](const rtm::CycleContext& ctx) {
        seen.push_back(ctx);
        return seen.size() < 5;  // the fifth cycle stops the activity from inside
      },
      fast(500'000));
  activity.start();
  ASSERT_TRUE(eventually([&] { return !activity.running(); }));
  activity.stop();
  ASSERT_EQ(seen.size(), 5u);
  for (std::size_t i = 0; i < seen.size(); ++i) {
    EXPECT_EQ(seen[i].cycle, i);
    EXPECT_EQ(seen[i].period_ns, 500'000);
    EXPECT_GE(seen[i].wake_ns, seen[i].deadline_ns);
  }
  EXPECT_EQ(activity.stats().cycles, 5u);
}

TEST(PeriodicActivity, FirstDeadlineFixesThePhaseOfEveryCycle) {
  constexpr std::int64_t kPeriod_ns = 1'000'000;
  // Ahead of now by far more than a start takes; should the start still come later, the first
  // cycle falls on the same grid (first_deadline()), which is what is checked.
  const std::int64_t requested_ns = rtm::monotonic_ns() + 50 * kPeriod_ns + 123'456;
  std::mutex mu;
  std::vector<std::int64_t> deadlines;
  rtm::PeriodicOptions options = fast(kPeriod_ns);
  options.first_deadline_ns = requested_ns;
  rtm::PeriodicActivity activity(
      [&](const rtm::CycleContext& ctx) {
        std::lock_guard lock(mu);
        deadlines.push_back(ctx.deadline_ns);
        return true;
      },
      options);
  activity.start();
  ASSERT_TRUE(eventually([&] {
    std::lock_guard lock(mu);
    return deadlines.size() >= 3;
  }));
  activity.stop();
  std::lock_guard lock(mu);
  EXPECT_GE(deadlines.front(), requested_ns);
  for (const std::int64_t d : deadlines) EXPECT_EQ((d - requested_ns) % kPeriod_ns, 0) << d;
}

TEST(PeriodicActivity, FirstDeadlineIsSetOnlyWhileStoppedAndNeverNegative) {
  rtm::PeriodicActivity activity([](const rtm::CycleContext&) { return true; }, fast());
  EXPECT_THROW(activity.set_first_deadline_ns(-1), std::invalid_argument);
  activity.set_first_deadline_ns(0);
  activity.start();
  EXPECT_THROW(activity.set_first_deadline_ns(rtm::monotonic_ns()), std::logic_error);
  activity.stop();
  rtm::PeriodicOptions negative = fast();
  negative.first_deadline_ns = -5;
  EXPECT_THROW(rtm::PeriodicActivity([](const rtm::CycleContext&) { return true; }, negative), std::invalid_argument);
}

TEST(PeriodicActivity, StopFromInsideACycleDoesNotDeadlock) {
  std::unique_ptr<rtm::PeriodicActivity> activity;
  std::atomic<long> cycles{0};
  activity = std::make_unique<rtm::PeriodicActivity>(
      [&](const rtm::CycleContext&) {
        if (++cycles == 3) activity->stop();
        return true;
      },
      fast());
  activity->start();
  ASSERT_TRUE(eventually([&] { return !activity->running(); }));
  activity->stop();
  EXPECT_EQ(cycles.load(), 3);
}

TEST(PeriodicActivity, StatsAreReadableWhileRunning) {
  rtm::PeriodicActivity activity([](const rtm::CycleContext&) { return true; }, fast(200'000));
  activity.start();
  std::atomic<bool> done{false};
  std::uint64_t last_cycles = 0;
  bool monotonic = true;
  std::thread reader([&] {
    while (!done) {
      const auto s = activity.stats();
      if (s.cycles < last_cycles) monotonic = false;
      last_cycles = s.cycles;
      if (s.lateness_p50_ns > s.lateness_max_ns && s.lateness_max_ns > 0) monotonic = false;
    }
  });
  ASSERT_TRUE(eventually([&] { return activity.stats().cycles > 50; }));
  done = true;
  reader.join();
  activity.stop();
  EXPECT_TRUE(monotonic);
  const auto s = activity.stats();
  EXPECT_EQ(s.period_ns, 200'000);
  EXPECT_GT(s.cycles, 50u);
  EXPECT_LE(s.lateness_p50_ns, s.lateness_p99_ns);
  EXPECT_LE(s.lateness_p99_ns, s.lateness_max_ns);
}

TEST(PeriodicActivity, UnprivilegedSettingsFallBackAndStillRun) {
  // Without CAP_SYS_NICE the FIFO request is refused (warning); with it, it is granted. Either
  // way the activity must run, pinned to CPU 0.
  rtm::PeriodicOptions o = fast();
  o.fifo_priority = 10;
  o.cpu = 0;
  o.lock_memory = false;
  std::atomic<long> cycles{0};
  rtm::PeriodicActivity activity([&](const rtm::CycleContext&) { return ++cycles, true; }, o);
  activity.start();
  EXPECT_TRUE(eventually([&] { return cycles.load() > 3; }));
  activity.stop();
}

TEST(OnArrivalActivity, RunsACycleWhenSignalled) {
  auto signal = std::make_shared<rtm::ArrivalSignal>();
  std::atomic<long> cycles{0};
  rtm::OnArrivalActivity activity([&](const rtm::CycleContext&) { return ++cycles, true; }, signal);
  activity.start();
  std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_EQ(cycles.load(), 0);  // nothing arrived, nothing ran
  signal->notify();
  ASSERT_TRUE(eventually([&] { return cycles.load() == 1; }));
  signal->notify();
  ASSERT_TRUE(eventually([&] { return cycles.load() == 2; }));
  activity.stop();
  EXPECT_FALSE(activity.running());
  signal->notify();
  std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_EQ(cycles.load(), 2);
  EXPECT_EQ(activity.stats().cycles, 2u);
}

// A datum that arrives right after on(), before the new thread has looked at the signal (a
// slow thread start on a loaded machine), still runs a cycle.
TEST(OnArrivalActivity, AnArrivalRightAfterStartIsNotLostToASlowThreadStart) {
  auto signal = std::make_shared<rtm::ArrivalSignal>();
  std::atomic<long> cycles{0};
  rtm::OnArrivalActivity activity([&](const rtm::CycleContext&) { return ++cycles, true; }, signal);
  for (long round = 1; round <= 50; ++round) {
    activity.start();
    signal->notify();  // at once: the thread has most likely not run yet
    ASSERT_TRUE(eventually([&] { return cycles.load() == round; }, 5s)) << "round " << round;
    activity.stop();
  }
}

TEST(SharedTick, RunsCyclesInOrderWithinOnePeriod) {
  rtm::SharedTick tick(fast());
  std::mutex mu;
  std::vector<std::pair<std::uint64_t, char>> log;
  for (char who : {'s', 'c', 'a'})
    tick.add([&, who](const rtm::CycleContext& ctx) {
      std::lock_guard lock(mu);
      log.emplace_back(ctx.cycle, who);
      return true;
    });
  tick.start();
  EXPECT_THROW(tick.add([](const rtm::CycleContext&) { return true; }), std::logic_error);
  ASSERT_TRUE(eventually([&] {
    std::lock_guard lock(mu);
    return log.size() >= 30;
  }));
  tick.stop();
  std::lock_guard lock(mu);
  for (std::size_t i = 0; i + 2 < log.size(); i += 3) {
    EXPECT_EQ(log[i].second, 's');
    EXPECT_EQ(log[i + 1].second, 'c');
    EXPECT_EQ(log[i + 2].second, 'a');
    EXPECT_EQ(log[i].first, log[i + 2].first);  // same cycle
  }
}

TEST(SharedTick, AFailingMemberSkipsTheRestAndStopsTheTick) {
  rtm::SharedTick tick(fast());
  std::atomic<long> first{0}, third{0};
  tick.add([&](const rtm::CycleContext&) { return ++first, true; });
  tick.add([&](const rtm::CycleContext& ctx) { return ctx.cycle < 4; });
  tick.add([&](const rtm::CycleContext&) { return ++third, true; });
  tick.start();
  ASSERT_TRUE(eventually([&] { return !tick.running(); }));
  tick.stop();
  EXPECT_EQ(first.load(), 5);
  EXPECT_EQ(third.load(), 4);
}

}  // namespace
