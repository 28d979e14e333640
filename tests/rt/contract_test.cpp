// SPDX-License-Identifier: Apache-2.0
// Timing contracts and their analysis: every expected number is worked out by hand in the
// comments, from the model in docs/timing.md, not read back from the implementation.
#include "rt/contract.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace {

using rtm::ChainContract;
using rtm::SchedClass;
using rtm::TimingAnalysis;
using rtm::TimingContract;
using rtm::TimingFinding;

constexpr std::int64_t kMs = 1'000'000;
constexpr std::int64_t kUs = 1'000;

rtm::MachineLimits machine(int cpus, double rt_share = 0.95) { return rtm::MachineLimits{cpus, rt_share}; }

TimingContract fifo(const std::string& name, int priority, std::int64_t period_ns, std::int64_t budget_ns,
                    int cpu = 0) {
  TimingContract c;
  c.component = name;
  c.sched = SchedClass::fifo;
  c.fifo_priority = priority;
  c.period_ns = period_ns;
  c.budget_ns = budget_ns;
  c.cpu = cpu;
  return c;
}

TimingContract other(const std::string& name, std::int64_t period_ns, std::int64_t budget_ns, int cpu = -1) {
  TimingContract c;
  c.component = name;
  c.period_ns = period_ns;
  c.budget_ns = budget_ns;
  c.cpu = cpu;
  return c;
}

TimingContract reservation(const std::string& name, std::int64_t period_ns, std::int64_t deadline_ns,
                           std::int64_t runtime_ns, std::int64_t budget_ns) {
  TimingContract c;
  c.component = name;
  c.sched = SchedClass::deadline;
  c.period_ns = period_ns;
  c.deadline_ns = deadline_ns;
  c.runtime_ns = runtime_ns;
  c.budget_ns = budget_ns;
  return c;
}

const rtm::ResponseBound& response(const TimingAnalysis& a, const std::string& component) {
  const auto found = std::find_if(a.responses.begin(), a.responses.end(),
                                  [&](const rtm::ResponseBound& r) { return r.component == component; });
  if (found == a.responses.end()) throw std::logic_error("no response for " + component);
  return *found;
}

// The findings about subject whose text contains part.
std::vector<TimingFinding> findings(const TimingAnalysis& a, const std::string& subject, const std::string& part = "") {
  std::vector<TimingFinding> out;
  for (const auto& f : a.findings)
    if (f.subject == subject && f.text.find(part) != std::string::npos) out.push_back(f);
  return out;
}

std::string all_findings(const TimingAnalysis& a) {
  std::string text;
  for (const auto& f : a.findings)
    text +=
        (f.severity == TimingFinding::Severity::refusal ? "refusal " : "warning ") + f.subject + ": " + f.text + "\n";
  return text;
}

// ============================ response times ==========================

TEST(TimingAnalysis, ThreeFifoTasksOnOneCpuHaveTheTextbookResponseTimes) {
  // C/T = 1/4, 2/6, 3/13 (ms), deadlines at the periods, rate-monotonic priorities.
  const auto a = rtm::analyse_timing(
      {fifo("t1", 30, 4 * kMs, 1 * kMs), fifo("t2", 20, 6 * kMs, 2 * kMs), fifo("t3", 10, 13 * kMs, 3 * kMs)}, {},
      machine(1));
  // t1: nothing above it: R = 1.
  // t2: 2 + ceil(2/4)*1 = 3; 2 + ceil(3/4)*1 = 3.
  // t3: 3 + ceil(3/4)*1 + ceil(3/6)*2 = 6; 3 + 2*1 + 1*2 = 7; 3 + 2*1 + 2*2 = 9; 3 + 3*1 + 2*2 = 10;
  //     3 + ceil(10/4)*1 + ceil(10/6)*2 = 3 + 3 + 4 = 10.
  EXPECT_EQ(response(a, "t1").response_ns, 1 * kMs);
  EXPECT_EQ(response(a, "t2").response_ns, 3 * kMs);
  EXPECT_EQ(response(a, "t3").response_ns, 10 * kMs);
  EXPECT_EQ(response(a, "t3").how, "budget 3 ms + interference 7 ms (t1 3×1 ms, t2 2×2 ms)");
  // 0.25 + 0.33 + 0.23 = 0.81 of CPU 0: within 1 and within 0.95.
  EXPECT_FALSE(a.refused()) << all_findings(a);
  EXPECT_TRUE(a.findings.empty()) << all_findings(a);
  ASSERT_EQ(a.cpus.size(), 1u);
  EXPECT_EQ(a.cpus[0].cpu, 0);
  EXPECT_NEAR(a.cpus[0].utilisation, 1.0 / 4 + 2.0 / 6 + 3.0 / 13, 1e-12);
  EXPECT_NEAR(a.cpus[0].rt_utilisation, a.cpus[0].utilisation, 1e-12);
}

TEST(TimingAnalysis, AnUnpinnedHigherPriorityComponentInterferesButOnePinnedToAnotherCpuDoesNot) {
  const auto a = rtm::analyse_timing(
      {fifo("k", 10, 10 * kMs, 1 * kMs, 0), fifo("h", 20, 10 * kMs, 2 * kMs, -1), fifo("x", 30, 10 * kMs, 3 * kMs, 1)},
      {}, machine(2, 1.0));
  // x (CPU 1): nothing at 30 or above may run there: R = 3.
  // h (any CPU): x may preempt it on CPU 1: 2 + ceil(2/10)*3 = 5; 2 + ceil(5/10)*3 = 5.
  // k (CPU 0): h may run there, x may not. h can run its budget late in its window (it runs on
  // other CPUs too): jitter R_h - C_h = 3. 1 + ceil((1+3)/10)*2 = 3; 1 + ceil((3+3)/10)*2 = 3.
  EXPECT_EQ(response(a, "x").response_ns, 3 * kMs);
  EXPECT_EQ(response(a, "h").response_ns, 5 * kMs);
  EXPECT_EQ(response(a, "k").response_ns, 3 * kMs);
  EXPECT_EQ(response(a, "k").how, "budget 1 ms + interference 2 ms (h 1×2 ms with jitter 3 ms)");
  EXPECT_FALSE(a.refused()) << all_findings(a);
  // Loads: CPU 0 has k (0.1), CPU 1 has x (0.3); h is on any CPU (0.2).
  ASSERT_EQ(a.cpus.size(), 2u);
  EXPECT_EQ(a.cpus[0].cpu, 0);
  EXPECT_NEAR(a.cpus[0].utilisation, 0.1, 1e-12);
  EXPECT_EQ(a.cpus[1].cpu, 1);
  EXPECT_NEAR(a.cpus[1].utilisation, 0.3, 1e-12);
  EXPECT_NEAR(a.unpinned_utilisation, 0.2, 1e-12);
}

TEST(TimingAnalysis, AnEqualPriorityComponentInterferes) {
  const auto a = rtm::analyse_timing(
      {fifo("a", 50, 10 * kMs, 1 * kMs), fifo("b", 50, 10 * kMs, 2 * kMs), fifo("lower", 49, 10 * kMs, 1 * kMs)}, {},
      machine(1, 1.0));
  // a: b may be running already and runs to its end: 1 + ceil(1/10)*2 = 3; again 3.
  // b: 2 + ceil(2/10)*1 = 3.
  // lower: 1 + 1 + 2 = 4; 1 + ceil(4/10)*1 + ceil(4/10)*2 = 4.
  EXPECT_EQ(response(a, "a").response_ns, 3 * kMs);
  EXPECT_EQ(response(a, "b").response_ns, 3 * kMs);
  EXPECT_EQ(response(a, "lower").response_ns, 4 * kMs);
}

TEST(TimingAnalysis, AnAwaitCountsInTheComponentsOwnResponse) {
  TimingContract c = fifo("c", 50, 10 * kMs, 1 * kMs);
  c.await_ns = 2 * kMs;
  const auto a = rtm::analyse_timing({c}, {}, machine(1));
  // Waits up to 2 ms for its datum, then runs 1 ms: 3 ms.
  EXPECT_EQ(response(a, "c").response_ns, 3 * kMs);
  EXPECT_EQ(response(a, "c").how, "await 2 ms + budget 1 ms");
}

TEST(TimingAnalysis, AnAwaitingHigherPriorityComponentCanRunLateThenOnTimeAgain) {
  TimingContract h = fifo("h", 20, 10 * kMs, 1 * kMs);
  h.await_ns = 6 * kMs;
  const auto a = rtm::analyse_timing({h, fifo("l", 10, 10 * kMs, 4 * kMs)}, {}, machine(1, 1.0));
  // h: 6 + 1 = 7. Its work may come late by R_h - C_h = 6 (jitter).
  // l: 4 + ceil((4+6)/10)*1 = 5; 4 + ceil((5+6)/10)*1 = 6; 4 + ceil((6+6)/10)*1 = 6.
  // The schedule that takes it: h released at 0 awaits until 6 and runs 6..7; l, released at 6,
  // runs 7..10; h's next job, released at 10 with its datum there, runs 10..11; l ends at 12, 6
  // after its release. Taking only the await as jitter would say 5.
  EXPECT_EQ(response(a, "h").response_ns, 7 * kMs);
  EXPECT_EQ(response(a, "l").response_ns, 6 * kMs);
  EXPECT_EQ(response(a, "l").how, "budget 4 ms + interference 2 ms (h 2×1 ms with jitter 6 ms)");
}

TEST(TimingAnalysis, AResponseAboveTheDeadlineIsRefusedNamingTheInterferers) {
  TimingContract k = fifo("k", 10, 10 * kMs, 2 * kMs);
  k.deadline_ns = 5 * kMs;
  const auto a =
      rtm::analyse_timing({fifo("h1", 30, 5 * kMs, 2 * kMs), fifo("h2", 20, 5 * kMs, 2 * kMs), k}, {}, machine(1, 1.0));
  // h1: 2. h2: 2 + ceil(2/5)*2 = 4; again 4.
  // k: 2 + ceil(2/5)*2 + ceil(2/5)*2 = 6 > 5: stop there.
  // Loads 0.4 + 0.4 + 0.2 = 1.0: not above the CPU.
  EXPECT_EQ(response(a, "h2").response_ns, 4 * kMs);
  EXPECT_FALSE(response(a, "k").response_ns.has_value());
  ASSERT_EQ(a.findings.size(), 1u) << all_findings(a);
  EXPECT_EQ(a.findings[0].severity, TimingFinding::Severity::refusal);
  EXPECT_EQ(a.findings[0].subject, "k");
  EXPECT_EQ(a.findings[0].text, "response bound 6 ms > deadline 5 ms on CPU 0 (interference from h1, h2)");
  EXPECT_TRUE(a.refused());
}

TEST(TimingAnalysis, SchedOtherHasNoBoundAndAChainThroughItIsWarnedNotRefused) {
  TimingContract s = fifo("s", 80, 2 * kMs, 100 * kUs, 1);
  ChainContract timed{"teleop", {"j.cmd", "s"}, 5 * kMs, 0};
  ChainContract untimed{"log", {"j.cmd", "s"}, 0, 0};
  const auto a = rtm::analyse_timing({other("j", 10 * kMs, 1 * kMs), s}, {timed, untimed}, machine(2));
  EXPECT_FALSE(response(a, "j").response_ns.has_value());
  EXPECT_EQ(response(a, "j").how, "SCHED_OTHER: the kernel gives no bound");
  EXPECT_TRUE(findings(a, "j").empty()) << "a SCHED_OTHER component alone is no finding";
  ASSERT_EQ(a.findings.size(), 1u) << all_findings(a);
  EXPECT_EQ(a.findings[0].severity, TimingFinding::Severity::warning);
  EXPECT_EQ(a.findings[0].subject, "chain teleop");
  EXPECT_EQ(a.findings[0].text, "cannot be bounded: j (SCHED_OTHER: the kernel gives no bound)");
  EXPECT_FALSE(a.refused());
  ASSERT_EQ(a.chains.size(), 2u);
  EXPECT_FALSE(a.chains[0].latency_ns.has_value());
  EXPECT_TRUE(a.chains[0].hops.empty());
  EXPECT_EQ(a.chains[1].how, "j (SCHED_OTHER: the kernel gives no bound)") << "no deadline, no max age: no warning";
}

TEST(TimingAnalysis, AnUndeclaredBudgetIsWarnedAndLeavesLowerPrioritiesWithoutABound) {
  const auto a =
      rtm::analyse_timing({fifo("u", 50, 10 * kMs, 0), fifo("l", 40, 10 * kMs, 1 * kMs)}, {}, machine(1, 1.0));
  EXPECT_FALSE(response(a, "u").response_ns.has_value());
  EXPECT_EQ(response(a, "u").how, "no budget declared");
  ASSERT_EQ(a.findings.size(), 1u) << all_findings(a);
  EXPECT_EQ(a.findings[0].severity, TimingFinding::Severity::warning);
  EXPECT_EQ(a.findings[0].subject, "u");
  EXPECT_EQ(a.findings[0].text, "no budget declared: its response cannot be bounded");
  EXPECT_FALSE(response(a, "l").response_ns.has_value());
  EXPECT_EQ(response(a, "l").how, "no bound: u may preempt it and declares no budget");
  EXPECT_FALSE(a.refused());
}

// ============================ utilisation =============================

TEST(TimingAnalysis, ACpuWhoseBudgetsExceedItIsRefusedNamingTheTotalAndEachShare) {
  // 4/10 + 5/10 + 3.3/10 = 0.40 + 0.50 + 0.33 = 1.23 of CPU 1.
  const auto a = rtm::analyse_timing(
      {other("a", 10 * kMs, 4 * kMs, 1), other("b", 10 * kMs, 5 * kMs, 1), other("c", 10 * kMs, 3'300 * kUs, 1)}, {},
      machine(2));
  ASSERT_EQ(a.findings.size(), 1u) << all_findings(a);
  EXPECT_EQ(a.findings[0].severity, TimingFinding::Severity::refusal);
  EXPECT_EQ(a.findings[0].subject, "CPU 1");
  EXPECT_EQ(a.findings[0].text, "budgets take 1.23 of it (a 0.40, b 0.50, c 0.33)");
  ASSERT_EQ(a.cpus.size(), 1u);
  EXPECT_NEAR(a.cpus[0].utilisation, 1.23, 1e-12);
  EXPECT_EQ(a.cpus[0].rt_utilisation, 0.0);
  ASSERT_EQ(a.cpus[0].shares.size(), 3u);
  EXPECT_EQ(a.cpus[0].shares[2].component, "c");
  EXPECT_NEAR(a.cpus[0].shares[2].utilisation, 0.33, 1e-12);
}

TEST(TimingAnalysis, RealTimeBudgetsAboveTheKernelsShareOfACpuAreRefused) {
  // 5/10 + 4.7/10 = 0.97 of CPU 0: within the CPU, above the 0.95 RT throttling leaves.
  // Responses: hi 5, lo 4.7 + ceil(9.7/10)*5 = 9.7 <= 10.
  const std::vector<TimingContract> contracts{fifo("hi", 20, 10 * kMs, 5 * kMs), fifo("lo", 10, 10 * kMs, 4'700 * kUs)};
  const auto a = rtm::analyse_timing(contracts, {}, machine(2, 0.95));
  ASSERT_EQ(a.findings.size(), 1u) << all_findings(a);
  EXPECT_EQ(a.findings[0].subject, "CPU 0");
  EXPECT_EQ(a.findings[0].text,
            "SCHED_FIFO and SCHED_DEADLINE budgets take 0.97 of it, above the 0.95 the kernel leaves them (hi 0.50, lo "
            "0.47)");
  EXPECT_EQ(response(a, "lo").response_ns, 9'700 * kUs);

  const auto unthrottled = rtm::analyse_timing(contracts, {}, machine(2, 1.0));
  EXPECT_FALSE(unthrottled.refused()) << all_findings(unthrottled);
}

TEST(TimingAnalysis, RealTimeBudgetsAboveTheShareOfAllCpusAreRefused) {
  // 0.9 on CPU 0, 0.9 on CPU 1 (each within 0.95), 0.2 on any CPU: 2.00 > 2 x 0.95 = 1.90.
  const auto a = rtm::analyse_timing({fifo("f0", 50, 10 * kMs, 9 * kMs, 0), fifo("f1", 50, 10 * kMs, 9 * kMs, 1),
                                      fifo("u", 40, 10 * kMs, 2 * kMs, -1)},
                                     {}, machine(2, 0.95));
  EXPECT_EQ(findings(a, "all CPUs").size(), 1u) << all_findings(a);
  EXPECT_EQ(findings(a, "all CPUs",
                     "SCHED_FIFO and SCHED_DEADLINE budgets take 2.00 of the 2 CPUs, above the 1.90 (2 × "
                     "0.95) the kernel leaves them")
                .size(),
            1u)
      << all_findings(a);
  EXPECT_TRUE(findings(a, "CPU 0").empty());
  EXPECT_TRUE(findings(a, "CPU 1").empty());
}

TEST(TimingAnalysis, BudgetsAboveAllCpusAreRefused) {
  // 3 x 8/10 = 2.40 of 2 CPUs, none pinned.
  const auto a = rtm::analyse_timing(
      {other("x", 10 * kMs, 8 * kMs), other("y", 10 * kMs, 8 * kMs), other("z", 10 * kMs, 8 * kMs)}, {}, machine(2));
  ASSERT_EQ(a.findings.size(), 1u) << all_findings(a);
  EXPECT_EQ(a.findings[0].subject, "all CPUs");
  EXPECT_EQ(a.findings[0].text, "budgets take 2.40 of the 2 CPUs");
  EXPECT_TRUE(a.cpus.empty());
  EXPECT_NEAR(a.unpinned_utilisation, 2.4, 1e-12);
}

// ============================ SCHED_DEADLINE ==========================

TEST(TimingAnalysis, AReservationBoundsTheResponseByItsPeriodAndPreemptsFifo) {
  const auto a = rtm::analyse_timing(
      {reservation("d", 10 * kMs, 0, 1 * kMs, 800 * kUs), fifo("f", 50, 10 * kMs, 2 * kMs, 0)}, {}, machine(2));
  EXPECT_EQ(response(a, "d").response_ns, 10 * kMs);
  EXPECT_EQ(response(a, "d").how, "SCHED_DEADLINE reservation of 1 ms every 10 ms within 10 ms");
  // f: d's runtime of 1 ms may run anywhere in its 10 ms window (jitter 10):
  // 2 + ceil((2+10)/10)*1 = 4; 2 + ceil((4+10)/10)*1 = 4.
  EXPECT_EQ(response(a, "f").response_ns, 4 * kMs);
  EXPECT_FALSE(a.refused()) << all_findings(a);
  EXPECT_NEAR(a.unpinned_utilisation, 0.1, 1e-12) << "the reservation, 1/10, not the budget";
}

TEST(TimingAnalysis, ReservationsAboveWhatTheKernelAdmitsAreRefused) {
  // 3 x 7/10 = 2.10 > 2 x 0.95 = 1.90.
  const auto a = rtm::analyse_timing(
      {reservation("d1", 10 * kMs, 0, 7 * kMs, 7 * kMs), reservation("d2", 10 * kMs, 0, 7 * kMs, 7 * kMs),
       reservation("d3", 10 * kMs, 0, 7 * kMs, 7 * kMs)},
      {}, machine(2, 0.95));
  EXPECT_EQ(findings(a, "all CPUs",
                     "SCHED_DEADLINE reservations take 2.10, above the 1.90 (2 × 0.95) the kernel admits: it would "
                     "refuse them")
                .size(),
            1u)
      << all_findings(a);
  EXPECT_TRUE(a.refused());
}

TEST(TimingAnalysis, AReservationThatAwaitsIsRefused) {
  TimingContract d = reservation("d", 10 * kMs, 0, 2 * kMs, 1 * kMs);
  d.await_ns = 1 * kMs;
  const auto a = rtm::analyse_timing({d}, {}, machine(2));
  // Waking 1 ms after its release, the kernel starts a new period: it ends by 1 + 10 = 11 ms.
  EXPECT_FALSE(response(a, "d").response_ns.has_value());
  EXPECT_EQ(findings(a, "d", "response bound 11 ms > deadline 10 ms").size(), 1u) << all_findings(a);
}

TEST(TimingAnalysis, AReservationWithADeadlineBelowItsPeriodIsRefused) {
  // Linux throttles a constrained reservation that wakes on the activity's own grid until its
  // own next period: the activity gives the kernel the period, and the contract may not ask less.
  const auto a = rtm::analyse_timing({reservation("d", 10 * kMs, 5 * kMs, 1 * kMs, 800 * kUs)}, {}, machine(2));
  EXPECT_FALSE(response(a, "d").response_ns.has_value());
  EXPECT_EQ(findings(a, "d", "deadline 5 ms below the period 10 ms with SCHED_DEADLINE").size(), 1u) << all_findings(a);
}

// ============================ validation ==============================

TEST(TimingAnalysis, EachMalformedContractIsRefusedAndLeftOut) {
  struct Case {
    std::function<void(TimingContract&)> change;
    std::string text;
  };
  const auto to_deadline = [](TimingContract& c) {
    c.sched = SchedClass::deadline;
    c.fifo_priority = 0;
    c.cpu = -1;
  };
  const std::vector<Case> cases{
      {[](TimingContract& c) { c.period_ns = 0; }, "period 0 is not above 0"},
      {[](TimingContract& c) { c.phase_ns = -1; }, "phase -1 ns is not within [0, the period 2 ms)"},
      {[](TimingContract& c) { c.phase_ns = 2 * kMs; }, "phase 2 ms is not within [0, the period 2 ms)"},
      {[](TimingContract& c) { c.deadline_ns = -1; }, "deadline -1 ns is negative"},
      {[](TimingContract& c) { c.deadline_ns = 3 * kMs; },
       "deadline 3 ms above the period 2 ms: cycles of one activity never overlap"},
      {[](TimingContract& c) { c.budget_ns = -1; }, "budget -1 ns is negative"},
      {[](TimingContract& c) {
         c.deadline_ns = 1 * kMs;
         c.budget_ns = 1'500 * kUs;
       },
       "budget 1.5 ms above the deadline 1 ms"},
      {[](TimingContract& c) { c.await_ns = -1; }, "await -1 ns is negative"},
      {[](TimingContract& c) { c.await_ns = 2 * kMs; }, "await 2 ms not below the deadline 2 ms"},
      {[](TimingContract& c) { c.cpu = -2; }, "CPU -2 is not on this machine, which has 2 CPUs"},
      {[](TimingContract& c) { c.cpu = 2; }, "CPU 2 is not on this machine, which has 2 CPUs"},
      {[](TimingContract& c) { c.fifo_priority = 0; }, "SCHED_FIFO priority 0 is outside 1..99"},
      {[](TimingContract& c) { c.fifo_priority = 100; }, "SCHED_FIFO priority 100 is outside 1..99"},
      {[](TimingContract& c) { c.sched = SchedClass::other; },
       "priority 10 with class other: only SCHED_FIFO takes one"},
      {[&](TimingContract& c) {
         to_deadline(c);
         c.cpu = 0;
       },
       "pinned to CPU 0: the kernel refuses SCHED_DEADLINE for a thread pinned to one CPU; leave cpu unset"},
      {[&](TimingContract& c) {
         to_deadline(c);
         c.budget_ns = 0;
       },
       "SCHED_DEADLINE without a runtime"},
      {[&](TimingContract& c) {
         to_deadline(c);
         c.runtime_ns = -1;
       },
       "runtime -1 ns is negative"},
      {[&](TimingContract& c) {
         to_deadline(c);
         c.budget_ns = 500 * kUs;
         c.runtime_ns = 2'200 * kUs;
       },
       "runtime 2.2 ms above the deadline 2 ms"},
      {[&](TimingContract& c) {
         to_deadline(c);
         c.runtime_ns = 200 * kUs;
       },
       "budget 500 us above its reservation 200 us"},
  };
  for (const auto& test : cases) {
    SCOPED_TRACE(test.text);
    TimingContract x = fifo("x", 10, 2 * kMs, 500 * kUs, 0);
    test.change(x);
    const auto a = rtm::analyse_timing({x}, {}, machine(2));
    EXPECT_TRUE(a.refused());
    EXPECT_EQ(findings(a, "x", test.text).size(), 1u) << all_findings(a);
    EXPECT_FALSE(response(a, "x").response_ns.has_value());
    EXPECT_EQ(response(a, "x").how.rfind("not analysed: ", 0), 0u) << response(a, "x").how;
    EXPECT_TRUE(a.cpus.empty()) << "left out of the loads";
    EXPECT_EQ(a.unpinned_utilisation, 0.0);
  }
}

TEST(TimingAnalysis, AComponentNameGivenTwiceIsRefusedAndOnlyTheFirstIsAnalysed) {
  const auto a =
      rtm::analyse_timing({fifo("x", 10, 2 * kMs, 500 * kUs), fifo("x", 20, 2 * kMs, 500 * kUs)}, {}, machine(1));
  ASSERT_EQ(a.findings.size(), 1u) << all_findings(a);
  EXPECT_EQ(a.findings[0].subject, "x");
  EXPECT_EQ(a.findings[0].text, "a component name given twice");
  ASSERT_EQ(a.responses.size(), 2u);
  EXPECT_EQ(a.responses[0].response_ns, 500 * kUs) << "the second, at priority 20, is not there to preempt it";
  EXPECT_FALSE(a.responses[1].response_ns.has_value());
}

// ============================ chains ==================================

// The demo: one 2 ms grid on CPU 1, the controller 0.1 ms after the sensor awaiting its wrench up
// to 0.15 ms, the actuator 0.1 ms later awaiting the controller's command up to 0.1 ms.
std::vector<TimingContract> demo(std::int64_t actuator_phase_ns = 200 * kUs) {
  TimingContract sensor = fifo("sensor0", 80, 2 * kMs, 50 * kUs, 1);
  sensor.phase_ns = 0;
  TimingContract controller = fifo("controller0", 79, 2 * kMs, 50 * kUs, 1);
  controller.phase_ns = 100 * kUs;
  controller.await_ns = 150 * kUs;
  TimingContract actuator = fifo("actuator0", 78, 2 * kMs, 50 * kUs, 1);
  actuator.phase_ns = actuator_phase_ns;
  actuator.await_ns = 100 * kUs;
  return {sensor, controller, actuator};
}

ChainContract wrist_to_drive(std::int64_t deadline_ns = 0, std::int64_t max_age_ns = 0) {
  return {"wrist_to_drive", {"sensor0.wrench", "controller0", "actuator0"}, deadline_ns, max_age_ns};
}

TEST(TimingChains, OnTheDemosGridOnlyTheWindowsThatOverlapInterfere) {
  const auto a = rtm::analyse_timing(demo(), {wrist_to_drive()}, machine(2));
  // Responses (us), all on CPU 1, one 2 ms grid; a job of j counts against k only when j's
  // window [phase_j, phase_j + R_j) overlaps k's [phase_k, phase_k + R_k):
  //   sensor0 (80): nothing above it: 50.
  //   controller0 (79): own 150 + 50 = 200, window [100, 300); sensor0's [0, 50) ends before it: 200.
  //   actuator0 (78): own 100 + 50 = 150, window [200, 350); sensor0's [0, 50) clear;
  //     controller0's [100, 300) overlaps: 150 + 50 = 200, window [200, 400): still 200.
  EXPECT_EQ(response(a, "sensor0").response_ns, 50 * kUs);
  EXPECT_EQ(response(a, "controller0").response_ns, 200 * kUs);
  EXPECT_EQ(response(a, "actuator0").response_ns, 200 * kUs);
  ASSERT_EQ(a.chains.size(), 1u);
  const rtm::ChainBound& chain = a.chains[0];
  ASSERT_EQ(chain.hops.size(), 2u);
  // sensor0 -> controller0: delta 100; sensor0 ends within 50 <= 100 + 150: read 100 after.
  EXPECT_EQ(chain.hops[0].writer, "sensor0");
  EXPECT_EQ(chain.hops[0].reader, "controller0");
  EXPECT_EQ(chain.hops[0].latency_ns, 100 * kUs);
  EXPECT_EQ(chain.hops[0].age_ns, 100 * kUs);
  EXPECT_EQ(chain.hops[0].how,
            "same 2 ms grid, phases 0 -> 100 us, writer ends within 50 us, reader awaits 150 us: 100 us");
  // controller0 -> actuator0: delta 100; controller0 ends within 200 <= 100 + 100: 100.
  EXPECT_EQ(chain.hops[1].latency_ns, 100 * kUs);
  EXPECT_EQ(chain.hops[1].age_ns, 100 * kUs);
  // 100 + 100 + actuator0's 200.
  EXPECT_EQ(chain.latency_ns, 400 * kUs);
  EXPECT_EQ(chain.age_ns, 400 * kUs);
  EXPECT_EQ(chain.last_response_ns, 200 * kUs);
  EXPECT_FALSE(a.refused()) << all_findings(a);
}

TEST(TimingChains, AControllerMayEndAfterTheActuatorStopsAwaitingAndThenCostsAPeriod) {
  // The controller awaits 0.2 ms: own 250 > 100 + 100, so the actuator's cycle released 100
  // after it may have stopped awaiting: the next one reads it, 100 + 2000 * ceil(50/2000).
  auto contracts = demo();
  contracts[1].await_ns = 200 * kUs;
  const auto a = rtm::analyse_timing(contracts, {wrist_to_drive()}, machine(2));
  EXPECT_EQ(response(a, "controller0").response_ns, 250 * kUs);
  ASSERT_EQ(a.chains[0].hops.size(), 2u);
  EXPECT_EQ(a.chains[0].hops[1].latency_ns, 2'100 * kUs);
}

TEST(TimingChains, AComponentAwaitingThePortTheChainEntersByWaitsOnlyAsLongAsItsWriterIsLate) {
  auto contracts = demo();
  contracts[1].await_port = "wrench";
  contracts[2].await_port = "twist";
  const ChainContract chain{"wrist_to_drive", {"sensor0.wrench", "controller0.wrench", "actuator0.twist"}, 0, 0};
  const auto a = rtm::analyse_timing(contracts, {chain}, machine(2));
  ASSERT_EQ(a.chains[0].hops.size(), 2u);
  // sensor0 ends within 50, before controller0's release 100 after it: controller0 waits 0
  // and ends within 200 - 150 + 0 = 50 on this chain. Then actuator0, released 100 after
  // controller0, waits 0 too: 200 - 100 = 100. Chain 100 + 100 + 100.
  EXPECT_EQ(a.chains[0].hops[0].latency_ns, 100 * kUs);
  EXPECT_EQ(a.chains[0].hops[1].latency_ns, 100 * kUs);
  EXPECT_EQ(a.chains[0].last_response_ns, 100 * kUs);
  EXPECT_EQ(a.chains[0].latency_ns, 300 * kUs);
  EXPECT_NE(a.chains[0].hops[0].how.find("awaits controller0.wrench, so waits at most 0 and ends within 50 us"),
            std::string::npos)
      << a.chains[0].hops[0].how;
  // Entering by another port than the awaited one, the await's bound stays.
  const ChainContract other{"other", {"sensor0.wrench", "controller0.reference", "actuator0"}, 0, 0};
  const auto b = rtm::analyse_timing(contracts, {other}, machine(2));
  EXPECT_EQ(b.chains[0].latency_ns, 400 * kUs);
}

// The demo as it runs: every loop inherits SCHED_FIFO 20 from chrt, the sensor and the joystick
// share phase 0, and the budgets are what one cycle takes on these machines.
TEST(TimingChains, AtOnePriorityOnlyJobsQueuedBeforeAComponentDelayItAndAnAwaitEndsWhenItsWriterEnds) {
  TimingContract sensor = fifo("sensor0", 20, 2 * kMs, 100 * kUs, 1);
  sensor.phase_ns = 0;
  TimingContract joystick = fifo("joystick0", 20, 2 * kMs, 60 * kUs, 1);
  joystick.phase_ns = 0;
  TimingContract controller = fifo("controller0", 20, 2 * kMs, 30 * kUs, 1);
  controller.phase_ns = 100 * kUs;
  controller.await_ns = 150 * kUs;
  controller.await_port = "wrench";
  TimingContract actuator = fifo("actuator0", 20, 2 * kMs, 50 * kUs, 1);
  actuator.phase_ns = 200 * kUs;
  actuator.await_ns = 100 * kUs;
  actuator.await_port = "twist";
  const ChainContract chain{"wrist_to_drive", {"sensor0.wrench", "controller0.wrench", "actuator0.twist"}, 350 * kUs, 0};
  const auto a = rtm::analyse_timing({sensor, joystick, controller, actuator}, {chain}, machine(2));
  // sensor0 never sleeps: of its equals only the joystick, released with it, may go first; the
  // controller and the actuator, released after it, queue behind it: 100 + 60 = 160.
  EXPECT_EQ(response(a, "sensor0").response_ns, 160 * kUs);
  EXPECT_EQ(response(a, "joystick0").response_ns, 160 * kUs);
  // controller0 sleeps in its await, so every equal whose window overlaps counts: own 150 + 30,
  // the sensor's [-100, 60) and the joystick's, and the actuator's from 100: 180 + 100 + 60 + 50.
  EXPECT_EQ(response(a, "controller0").response_ns, 390 * kUs);
  // actuator0: own 150, and the controller's window [-100, 290): 180.
  EXPECT_EQ(response(a, "actuator0").response_ns, 180 * kUs);
  ASSERT_EQ(a.chains[0].hops.size(), 2u);
  // On the chain the controller waits at most 160 - 100 = 60, then runs its 30 with no window
  // left open after 60 (the sensor's and joystick's end there, the actuator starts at 100): 90.
  // The actuator, released 100 after it, then waits 0 and runs 50 beside the controller's
  // (standalone) window that covers its release: 80. Chain 100 + 100 + 80.
  EXPECT_EQ(a.chains[0].hops[0].latency_ns, 100 * kUs);
  EXPECT_EQ(a.chains[0].hops[1].latency_ns, 100 * kUs);
  EXPECT_NE(a.chains[0].hops[0].how.find("so waits at most 60 us and ends within 90 us"), std::string::npos)
      << a.chains[0].hops[0].how;
  EXPECT_EQ(a.chains[0].last_response_ns, 80 * kUs);
  EXPECT_EQ(a.chains[0].latency_ns, 280 * kUs);
  EXPECT_FALSE(a.refused()) << all_findings(a);
}

TEST(TimingChains, AReaderPhasedAfterTheWritersBoundReadsInTheSameCycle) {
  auto contracts = demo(250 * kUs);
  contracts[1].await_ns = 300 * kUs;  // controller0 own 350, window [100, 450)
  const auto a = rtm::analyse_timing(contracts, {wrist_to_drive()}, machine(2));
  // actuator0: own 150, window [250, 400); controller0's [100, 450) overlaps: 200.
  // controller0 -> actuator0: delta 150; 350 <= 150 + 100? no: 150 + 2000 = 2150.
  // With the actuator awaiting 0.2 ms instead: 350 <= 150 + 200: 150.
  ASSERT_EQ(a.chains.size(), 1u);
  ASSERT_EQ(a.chains[0].hops.size(), 2u);
  EXPECT_EQ(a.chains[0].hops[1].latency_ns, 2'150 * kUs);
  contracts[2].await_ns = 200 * kUs;
  const auto b = rtm::analyse_timing(contracts, {wrist_to_drive()}, machine(2));
  // actuator0: own 250, window [250, 500), controller0 overlaps: 300. Chain 100 + 150 + 300.
  EXPECT_EQ(b.chains[0].hops[1].latency_ns, 150 * kUs);
  EXPECT_EQ(b.chains[0].latency_ns, 550 * kUs);
  EXPECT_EQ(b.chains[0].age_ns, 550 * kUs);
}

TEST(TimingChains, AWriterEndingAfterTheReadersReleaseAndAwaitCostsOneMorePeriod) {
  TimingContract w = fifo("w", 50, 10 * kMs, 3 * kMs, 0);
  w.phase_ns = 0;
  TimingContract r = fifo("r", 40, 10 * kMs, 1 * kMs, 1);
  r.phase_ns = 2 * kMs;
  const ChainContract chain{"w_to_r", {"w.out", "r"}, 0, 0};
  // w ends within 3 ms; r is released 2 ms after w and reads at once: 3 > 2 + 0, so the
  // datum waits for r's next cycle: 2 + 10 * ceil((3 - 2 - 0)/10) = 12 ms; chain 12 + 1 = 13.
  const auto late = rtm::analyse_timing({w, r}, {chain}, machine(2));
  ASSERT_EQ(late.chains[0].hops.size(), 1u);
  EXPECT_EQ(late.chains[0].hops[0].latency_ns, 12 * kMs);
  EXPECT_EQ(late.chains[0].latency_ns, 13 * kMs);
  // Awaiting 1 ms, r takes it in the same cycle: 3 <= 2 + 1: 2 ms; chain 2 + (1 + 1) = 4.
  r.await_ns = 1 * kMs;
  const auto awaited = rtm::analyse_timing({w, r}, {chain}, machine(2));
  EXPECT_EQ(awaited.chains[0].hops[0].latency_ns, 2 * kMs);
  EXPECT_EQ(awaited.chains[0].latency_ns, 4 * kMs);
}

// A writer every 2 ms and a reader every 5 ms; a second writer every 5 ms without a phase.
std::vector<TimingContract> unsynchronised() {
  TimingContract w = fifo("w", 50, 2 * kMs, 500 * kUs, 0);
  w.phase_ns = 0;
  TimingContract r = fifo("r", 40, 5 * kMs, 1 * kMs, 1);
  r.phase_ns = 0;
  return {w, r, fifo("w5", 45, 5 * kMs, 500 * kUs, 0)};
}

TEST(TimingChains, AnUnsynchronisedHopCostsTheWritersResponseAndOneReaderPeriod) {
  const auto a = rtm::analyse_timing(
      unsynchronised(), {ChainContract{"fast", {"w.out", "r"}, 0, 0}, ChainContract{"unphased", {"w5.out", "r"}, 0, 0}},
      machine(2));
  // Responses: w 0.5; r 1 (alone on CPU 1); w5 below w on CPU 0: 0.5 + ceil(0.5/2)*0.5 = 1; again 1.
  ASSERT_EQ(a.chains.size(), 2u);
  // fast: periods differ, phases or not. Latency 0.5 + 5 = 5.5, age 2 + 0.5 = 2.5; + r's 1.
  ASSERT_EQ(a.chains[0].hops.size(), 1u);
  EXPECT_EQ(a.chains[0].hops[0].latency_ns, 5'500 * kUs);
  EXPECT_EQ(a.chains[0].hops[0].age_ns, 2'500 * kUs);
  EXPECT_EQ(a.chains[0].hops[0].how,
            "no common grid: writer ends within 500 us, reader released every 5 ms: latency 5.5 ms, age 2.5 ms");
  EXPECT_EQ(a.chains[0].latency_ns, 6'500 * kUs);
  EXPECT_EQ(a.chains[0].age_ns, 3'500 * kUs);
  // unphased: the same period, but w5 has no phase. Latency 1 + 5 = 6, age 5 + 1 = 6; + 1.
  ASSERT_EQ(a.chains[1].hops.size(), 1u);
  EXPECT_EQ(a.chains[1].hops[0].latency_ns, 6 * kMs);
  EXPECT_EQ(a.chains[1].hops[0].age_ns, 6 * kMs);
  EXPECT_EQ(a.chains[1].latency_ns, 7 * kMs);
  EXPECT_EQ(a.chains[1].age_ns, 7 * kMs);
}

TEST(TimingChains, LatencyAboveTheChainsDeadlineIsRefused) {
  // The demo's 400 us (worked out above) against 300 us.
  const auto a = rtm::analyse_timing(demo(), {wrist_to_drive(300 * kUs)}, machine(2));
  ASSERT_EQ(a.findings.size(), 1u) << all_findings(a);
  EXPECT_EQ(a.findings[0].subject, "chain wrist_to_drive");
  EXPECT_EQ(a.findings[0].text, "latency bound 400 us > deadline 300 us");
  const auto kept = rtm::analyse_timing(demo(), {wrist_to_drive(400 * kUs)}, machine(2));
  EXPECT_FALSE(kept.refused()) << "a bound equal to the deadline keeps it";
}

TEST(TimingChains, AgeAboveTheChainsMaxAgeIsRefused) {
  // fast: latency 6.5 ms within its 7 ms deadline, age 3.5 ms above its 3 ms.
  const auto a =
      rtm::analyse_timing(unsynchronised(), {ChainContract{"fast", {"w.out", "r"}, 7 * kMs, 3 * kMs}}, machine(2));
  ASSERT_EQ(a.findings.size(), 1u) << all_findings(a);
  EXPECT_EQ(a.findings[0].subject, "chain fast");
  EXPECT_EQ(a.findings[0].text, "age bound 3.5 ms > max age 3 ms");
}

TEST(TimingChains, EachMalformedChainIsRefused) {
  struct Case {
    ChainContract chain;
    std::string subject, text;
  };
  const std::vector<Case> cases{
      {{"c", {"sensor0"}, 0, 0}, "chain c", "the path starts with 'sensor0', not component.port"},
      {{"c", {"sensor0.wrench"}, 0, 0}, "chain c", "at least one component after it"},
      {{"c", {".wrench", "controller0"}, 0, 0}, "chain c", "the path starts with '.wrench', not component.port"},
      {{"c", {"sensor0.", "controller0"}, 0, 0}, "chain c", "the path starts with 'sensor0.', not component.port"},
      {{"c", {"ghost.out", "controller0"}, 0, 0}, "chain c", "'ghost' has no contract"},
      {{"c", {"sensor0.wrench", "ghost"}, 0, 0}, "chain c", "'ghost' has no contract"},
      {{"c", {"sensor0.wrench", "controller0.in.x"}, 0, 0}, "chain c", "'controller0.in.x' is neither a component nor component.inport"},
      {{"c", {"sensor0.wrench", "controller0."}, 0, 0}, "chain c", "'controller0.' is neither a component nor component.inport"},
      {{"c", {"sensor0.wrench", "sensor0"}, 0, 0}, "chain c", "'sensor0' twice in a row"},
      {{"c", {"sensor0.wrench", "controller0", "controller0"}, 0, 0}, "chain c", "'controller0' twice in a row"},
      {{"Wrist", {"sensor0.wrench", "controller0"}, 0, 0}, "chain Wrist", "name 'Wrist' is not lower-case"},
      {{"", {"sensor0.wrench", "controller0"}, 0, 0}, "chain (no name)", "name '' is not lower-case"},
      {{"c", {"sensor0.wrench", "controller0"}, -1, 0}, "chain c", "deadline -1 ns is negative"},
      {{"c", {"sensor0.wrench", "controller0"}, 0, -1}, "chain c", "max age -1 ns is negative"},
  };
  for (const auto& test : cases) {
    SCOPED_TRACE(test.text);
    const auto a = rtm::analyse_timing(demo(), {test.chain}, machine(2));
    EXPECT_TRUE(a.refused());
    EXPECT_EQ(findings(a, test.subject, test.text).size(), 1u) << all_findings(a);
    ASSERT_EQ(a.chains.size(), 1u);
    EXPECT_FALSE(a.chains[0].latency_ns.has_value());
    EXPECT_TRUE(a.chains[0].hops.empty());
  }
  // A component may come back later in the path, just not twice in a row.
  const auto loop =
      rtm::analyse_timing(demo(), {{"loop", {"sensor0.wrench", "controller0", "sensor0"}, 0, 0}}, machine(2));
  EXPECT_FALSE(loop.refused()) << all_findings(loop);
}

// ============================ explain =================================

TEST(TimingAnalysis, ExplainShowsEachHopAndEachFinding) {
  const auto a = rtm::analyse_timing(demo(), {wrist_to_drive(300 * kUs)}, machine(2));
  const std::string text = a.explain();
  EXPECT_NE(text.find("CPU 1: "), std::string::npos) << text;
  EXPECT_NE(text.find("controller0  response <= 200 us (await 150 us + budget 50 us)"), std::string::npos) << text;
  EXPECT_NE(text.find("actuator0    response <= 200 us (await 100 us + budget 50 us + interference 50 us (controller0 "
                      "1×50 us on its grid 1.9 ms after it))"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("chain wrist_to_drive: sensor0 -> controller0 -> actuator0: latency <= 400 us, age <= 400 us"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("  sensor0 -> controller0: latency 100 us, age 100 us (same 2 ms grid, phases 0 -> 100 us, "
                      "writer ends within 50 us, reader awaits 150 us: 100 us)"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("  controller0 -> actuator0: latency 100 us, age 100 us"), std::string::npos) << text;
  EXPECT_NE(text.find("  actuator0 ends within 200 us"), std::string::npos) << text;
  EXPECT_NE(text.find("refused: chain wrist_to_drive: latency bound 400 us > deadline 300 us"), std::string::npos)
      << text;
}

// ============================ words and the machine ===================

TEST(FormatDuration, PicksTheUnitBySizeAndDropsTrailingZeros) {
  EXPECT_EQ(rtm::format_duration(2'000'000), "2 ms");
  EXPECT_EQ(rtm::format_duration(150'000), "150 us");
  EXPECT_EQ(rtm::format_duration(1'250'000), "1.25 ms");
  EXPECT_EQ(rtm::format_duration(850), "850 ns");
  EXPECT_EQ(rtm::format_duration(0), "0");
  EXPECT_EQ(rtm::format_duration(999), "999 ns");
  EXPECT_EQ(rtm::format_duration(1'000), "1 us");
  EXPECT_EQ(rtm::format_duration(1'500), "1.5 us");
  EXPECT_EQ(rtm::format_duration(-1'500'000), "-1.5 ms");
}

TEST(FormatDuration, RoundsToThreeDecimals) {
  EXPECT_EQ(rtm::format_duration(1'234'567), "1.235 ms");  // 1.234567 ms
  EXPECT_EQ(rtm::format_duration(1'234'499), "1.234 ms");
  EXPECT_EQ(rtm::format_duration(1'999'600), "2 ms") << "the carry reaches the whole milliseconds";
  // The most negative value has no positive counterpart: 9223372036854.775808 ms.
  EXPECT_EQ(rtm::format_duration(std::numeric_limits<std::int64_t>::min()), "-9223372036854.776 ms");
}

TEST(MachineLimits, ThisMachineHasAtLeastOneCpuAndAShareOfEach) {
  const rtm::MachineLimits m = rtm::machine_limits();
  EXPECT_GE(m.cpus, 1);
  EXPECT_GT(m.rt_share, 0.0);
  EXPECT_LE(m.rt_share, 1.0);
}

TEST(SchedClassName, NamesEachClass) {
  EXPECT_STREQ(rtm::sched_class_name(SchedClass::other), "other");
  EXPECT_STREQ(rtm::sched_class_name(SchedClass::fifo), "fifo");
  EXPECT_STREQ(rtm::sched_class_name(SchedClass::deadline), "deadline");
}

}  // namespace
