// SPDX-License-Identifier: Apache-2.0
#include "rt/activity.h"

#include <gtest/gtest.h>

#include <stdexcept>

namespace {

constexpr std::int64_t kPeriod_ns = 2'000'000;

TEST(Schedule, GridPointAtOrAfterStepsForwardFromAnEarlierOrigin) {
  const std::int64_t origin = 7 * kPeriod_ns + 123;
  EXPECT_EQ(rtm::grid_point_at_or_after(origin, kPeriod_ns, origin + 5 * kPeriod_ns + 1), origin + 6 * kPeriod_ns);
  EXPECT_EQ(rtm::grid_point_at_or_after(origin, kPeriod_ns, origin + 5 * kPeriod_ns), origin + 5 * kPeriod_ns)
      << "a point exactly at now is taken";
}

TEST(Schedule, GridPointAtOrAfterStepsBackFromALaterOrigin) {
  const std::int64_t origin = 100 * kPeriod_ns + 700'000;
  const std::int64_t now = 90 * kPeriod_ns;
  const std::int64_t point = rtm::grid_point_at_or_after(origin, kPeriod_ns, now);
  EXPECT_EQ(point, 90 * kPeriod_ns + 700'000);
  EXPECT_EQ((origin - point) % kPeriod_ns, 0);
}

TEST(Schedule, GridPointRefusesANonPositivePeriod) {
  EXPECT_THROW(rtm::grid_point_at_or_after(0, 0, 5), std::invalid_argument);
}

TEST(Schedule, FirstDeadlineZeroMeansNow) { EXPECT_EQ(rtm::first_deadline(0, kPeriod_ns, 42 * kPeriod_ns), 42 * kPeriod_ns); }

TEST(Schedule, FirstDeadlineAheadIsTakenAsIs) {
  const std::int64_t now = 42 * kPeriod_ns;
  EXPECT_EQ(rtm::first_deadline(now + 5 * kPeriod_ns + 17, kPeriod_ns, now), now + 5 * kPeriod_ns + 17);
}

TEST(Schedule, FirstDeadlineAlreadyPastKeepsItsPhase) {
  // Asked for 300 us before a cycle that has gone by 2.4 periods: the next point of that grid.
  const std::int64_t requested = 50 * kPeriod_ns - 300'000;
  const std::int64_t now = requested + 2 * kPeriod_ns + 800'000;
  const std::int64_t first = rtm::first_deadline(requested, kPeriod_ns, now);
  EXPECT_EQ(first, requested + 3 * kPeriod_ns);
  EXPECT_GE(first, now);
}

TEST(Schedule, OnTimeCycleTakesTheNextGridPoint) {
  const auto step = rtm::next_deadline(10 * kPeriod_ns, kPeriod_ns, 10 * kPeriod_ns + 300'000);
  EXPECT_EQ(step.next_deadline_ns, 11 * kPeriod_ns);
  EXPECT_EQ(step.skipped, 0u);
  EXPECT_FALSE(step.overrun);
}

TEST(Schedule, LateCycleDoesNotShiftLaterDeadlines) {
  // Finished 1.5 periods after its deadline: the next deadline (0.5 periods ago) is still taken.
  const std::int64_t d = 10 * kPeriod_ns;
  const auto step = rtm::next_deadline(d, kPeriod_ns, d + kPeriod_ns + kPeriod_ns / 2);
  EXPECT_EQ(step.next_deadline_ns, d + kPeriod_ns);
  EXPECT_EQ(step.skipped, 0u);
  EXPECT_FALSE(step.overrun);
}

TEST(Schedule, MoreThanOnePeriodLateSkipsMissedDeadlinesOnTheGrid) {
  const std::int64_t d = 10 * kPeriod_ns;
  // Finished 3.5 periods after its deadline: d+1p, d+2p, d+3p are gone; d+4p is next.
  const auto step = rtm::next_deadline(d, kPeriod_ns, d + 3 * kPeriod_ns + kPeriod_ns / 2);
  EXPECT_TRUE(step.overrun);
  EXPECT_EQ(step.skipped, 3u);
  EXPECT_EQ(step.next_deadline_ns, d + 4 * kPeriod_ns);
  EXPECT_EQ((step.next_deadline_ns - d) % kPeriod_ns, 0);
}

TEST(Schedule, ExactlyTwoPeriodsLateIsAnOverrun) {
  const std::int64_t d = 0;
  const auto step = rtm::next_deadline(d, kPeriod_ns, 2 * kPeriod_ns);
  EXPECT_TRUE(step.overrun);
  EXPECT_EQ(step.skipped, 2u);
  EXPECT_EQ(step.next_deadline_ns, 3 * kPeriod_ns);
}

TEST(Schedule, DeadlinesStayOnTheGridOverManyIrregularCycles) {
  const std::int64_t start = 123'456'789;
  std::int64_t deadline = start;
  const std::int64_t cycle_costs_ns[] = {100'000, 2'500'000, 7'100'000, 0, 1'999'999, 4'000'000, 50'000};
  for (int round = 0; round < 100; ++round) {
    const std::int64_t cost = cycle_costs_ns[round % 7];
    const auto step = rtm::next_deadline(deadline, kPeriod_ns, deadline + cost);
    ASSERT_GT(step.next_deadline_ns, deadline);
    ASSERT_EQ((step.next_deadline_ns - start) % kPeriod_ns, 0) << "round " << round;
    ASSERT_EQ(step.next_deadline_ns - deadline, static_cast<std::int64_t>(step.skipped + 1) * kPeriod_ns);
    deadline = step.next_deadline_ns;
  }
}

TEST(LatenessHistogram, PercentilesAndMaxFromKnownSamples) {
  rtm::LatenessHistogram h;
  EXPECT_EQ(h.percentile_ns(0.5), 0);
  for (int i = 0; i < 98; ++i) h.record(10'500);  // 10.5 us -> bucket [10, 11) us
  h.record(2'500'000);                            // 2.5 ms -> bucket [2, 3) ms
  h.record(-5);                                   // early wake counts as 0
  EXPECT_EQ(h.count(), 100u);
  EXPECT_EQ(h.percentile_ns(0.50), 11'000);
  EXPECT_EQ(h.percentile_ns(0.98), 11'000);
  EXPECT_EQ(h.percentile_ns(0.995), 2'500'000);  // bucket edge 3 ms, capped at the exact max
  EXPECT_EQ(h.max_ns(), 2'500'000);
  h.record(5'000'000'000);  // beyond 1 s: overflow bucket, exact max
  EXPECT_EQ(h.max_ns(), 5'000'000'000);
  EXPECT_EQ(h.percentile_ns(1.0), 5'000'000'000);
  h.clear();
  EXPECT_EQ(h.count(), 0u);
  EXPECT_EQ(h.max_ns(), 0);
}

TEST(PeriodicActivity, RejectsANonPositivePeriod) {
  rtm::PeriodicOptions options;
  options.period_ns = 0;
  EXPECT_THROW(rtm::PeriodicActivity([](const rtm::CycleContext&) { return true; }, options),
               std::invalid_argument);
}

}  // namespace

namespace {

// ============================ PeriodicSchedule ========================

TEST(PeriodicSchedule, StartsAtTheRequestedDeadlineAndStepsOnTheGrid) {
  rtm::PeriodicSchedule s(kPeriod_ns);
  const std::int64_t t0 = 1000 * kPeriod_ns;
  s.start(t0 + 3 * kPeriod_ns, t0);
  EXPECT_EQ(s.deadline_ns(), t0 + 3 * kPeriod_ns);
  const rtm::CycleContext first = s.begin(s.deadline_ns() + 10'000);
  EXPECT_EQ(first.cycle, 0u);
  EXPECT_EQ(first.deadline_ns, t0 + 3 * kPeriod_ns);
  EXPECT_EQ(first.wake_ns - first.deadline_ns, 10'000);
  EXPECT_EQ(first.period_ns, kPeriod_ns);
  s.end(first.wake_ns + 50'000);
  EXPECT_EQ(s.deadline_ns(), t0 + 4 * kPeriod_ns);
  EXPECT_EQ(s.begin(s.deadline_ns()).cycle, 1u);
  s.end(s.deadline_ns());
  const rtm::ActivityStats stats = s.stats();
  EXPECT_EQ(stats.cycles, 2u);
  EXPECT_EQ(stats.overruns, 0u);
  EXPECT_EQ(stats.lateness_max_ns, 10'000);
  EXPECT_DOUBLE_EQ(stats.mean_period_error_ns, -10'000.0) << "the second wake came one period minus 10 us later";
}

// pa10-sim's loop after waking at woke_ns: every step due by then, as the schedule allows.
int run_due_steps(rtm::PeriodicSchedule& s, std::int64_t woke_ns) {
  int steps = 0;
  while (woke_ns >= s.deadline_ns()) {
    s.begin(woke_ns);
    s.end(woke_ns);
    ++steps;
  }
  return steps;
}

TEST(PeriodicSchedule, OneStallWithinTheCatchUpRunsEveryMissedCycle) {
  // pa10-sim's physics: a 5 ms stall of a 1 ms schedule runs the 5 missed steps at once.
  constexpr std::int64_t kStep = 1'000'000;
  rtm::PeriodicSchedule s(kStep, 20 * kStep);
  s.start(kStep, 0);
  const int steps = run_due_steps(s, kStep + 5 * kStep + 300'000);
  EXPECT_EQ(steps, 6) << "the step due at 1 ms and the five due while stalled";
  EXPECT_EQ(s.deadline_ns(), 7 * kStep);
  EXPECT_EQ(s.stats().skipped, 0u);
  EXPECT_GE(s.stats().overruns, 1u) << "the steps that began more than one step late are counted";
}

TEST(PeriodicSchedule, AStallLongerThanTheCatchUpIsSkippedOnTheGrid) {
  constexpr std::int64_t kStep = 1'000'000;
  rtm::PeriodicSchedule s(kStep, 20 * kStep);
  s.start(kStep, 0);
  const int steps = run_due_steps(s, kStep + 50 * kStep + 400'000);
  EXPECT_EQ(steps, 1) << "a 50 ms stall is not replayed in a burst";
  EXPECT_EQ(s.deadline_ns(), 52 * kStep) << "the next step is the grid's next point after the stall";
  EXPECT_EQ(s.stats().skipped, 50u);
  EXPECT_EQ(s.stats().overruns, 1u);
}

TEST(PeriodicSchedule, RefusesANonPositivePeriodOrANegativeCatchUp) {
  EXPECT_THROW(rtm::PeriodicSchedule(0), std::invalid_argument);
  EXPECT_THROW(rtm::PeriodicSchedule(kPeriod_ns, -1), std::invalid_argument);
}

TEST(Schedule, NextDeadlineWithALongerCatchUpKeepsLateDeadlines) {
  const rtm::ScheduleStep step = rtm::next_deadline(0, kPeriod_ns, 3 * kPeriod_ns, 10 * kPeriod_ns);
  EXPECT_FALSE(step.overrun);
  EXPECT_EQ(step.next_deadline_ns, kPeriod_ns) << "two periods behind, within the catch-up: taken";
  EXPECT_EQ(step.skipped, 0u);
}

}  // namespace
