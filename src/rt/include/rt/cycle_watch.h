// SPDX-License-Identifier: Apache-2.0
// A cycle watched against its contract (rt/contract.h): how long each cycle ran against its
// execution budget, and when it ended against its deadline. record() runs on the loop's
// thread once per cycle with times the loop already has: no lock, no allocation, no system
// call. stats() is safe from any thread meanwhile.
#pragma once

#include <atomic>
#include <cstdint>

#include "rt/clock.h"
#include "rt/histogram.h"

namespace rtm {

// What a cycle is held to; 0: that limit is not watched (its histogram is still kept).
struct CycleLimits {
  std::int64_t budget_ns = 0;    // the longest one cycle may run, from its start to its end
  std::int64_t deadline_ns = 0;  // the latest it may end, after its release (the time it was due)
};

// What one cycle did against its limits.
struct CycleVerdict {
  bool over_budget = false;
  bool missed_deadline = false;
};

// A snapshot (units in the names). *_at_ns: CLOCK_REALTIME of the cycle that set the maximum
// (0: none yet), so a tool can say when the worst case was.
struct CycleWatchStats {
  CycleLimits limits;
  std::uint64_t cycles = 0;
  std::uint64_t over_budget = 0;
  std::uint64_t missed_deadline = 0;
  std::int64_t cycle_p50_ns = 0, cycle_p99_ns = 0, cycle_max_ns = 0, cycle_max_at_ns = 0;
  std::int64_t response_p50_ns = 0, response_p99_ns = 0, response_max_ns = 0, response_max_at_ns = 0;
};

class CycleWatch {
 public:
  // Before the loop runs, or between runs (not concurrently with record()).
  void set_limits(CycleLimits limits) {
    budget_ns_.store(limits.budget_ns, std::memory_order_relaxed);
    deadline_ns_.store(limits.deadline_ns, std::memory_order_relaxed);
  }
  CycleLimits limits() const {
    return {budget_ns_.load(std::memory_order_relaxed), deadline_ns_.load(std::memory_order_relaxed)};
  }

  // The cycle released (due) at release_ns ran from start_ns to end_ns (CLOCK_MONOTONIC).
  CycleVerdict record(std::int64_t release_ns, std::int64_t start_ns, std::int64_t end_ns) {
    const std::int64_t cycle_ns = end_ns - start_ns;
    const std::int64_t response_ns = end_ns - release_ns;
    const bool new_cycle_max = cycle_ns > cycle_.max_ns();
    const bool new_response_max = response_ns > response_.max_ns();
    cycle_.record(cycle_ns);
    response_.record(response_ns);
    // A new worst case is rare: the one extra clock read is paid then only.
    if (new_cycle_max || new_response_max) {
      const std::int64_t now = realtime_ns();
      if (new_cycle_max) cycle_max_at_ns_.store(now, std::memory_order_relaxed);
      if (new_response_max) response_max_at_ns_.store(now, std::memory_order_relaxed);
    }
    CycleVerdict verdict;
    const std::int64_t budget = budget_ns_.load(std::memory_order_relaxed);
    const std::int64_t deadline = deadline_ns_.load(std::memory_order_relaxed);
    if (budget > 0 && cycle_ns > budget) {
      verdict.over_budget = true;
      over_budget_.fetch_add(1, std::memory_order_relaxed);
    }
    if (deadline > 0 && response_ns > deadline) {
      verdict.missed_deadline = true;
      missed_deadline_.fetch_add(1, std::memory_order_relaxed);
    }
    return verdict;
  }

  // The counts alone, without the percentiles stats() works out.
  std::uint64_t over_budget() const { return over_budget_.load(std::memory_order_relaxed); }
  std::uint64_t missed_deadline() const { return missed_deadline_.load(std::memory_order_relaxed); }

  CycleWatchStats stats() const {
    CycleWatchStats s;
    s.limits = limits();
    s.cycles = cycle_.count();
    s.over_budget = over_budget();
    s.missed_deadline = missed_deadline();
    s.cycle_p50_ns = cycle_.percentile_ns(0.50);
    s.cycle_p99_ns = cycle_.percentile_ns(0.99);
    s.cycle_max_ns = cycle_.max_ns();
    s.cycle_max_at_ns = cycle_max_at_ns_.load(std::memory_order_relaxed);
    s.response_p50_ns = response_.percentile_ns(0.50);
    s.response_p99_ns = response_.percentile_ns(0.99);
    s.response_max_ns = response_.max_ns();
    s.response_max_at_ns = response_max_at_ns_.load(std::memory_order_relaxed);
    return s;
  }

  const LatencyHistogram& cycle_histogram() const { return cycle_; }
  const LatencyHistogram& response_histogram() const { return response_; }

 private:
  std::atomic<std::int64_t> budget_ns_{0};
  std::atomic<std::int64_t> deadline_ns_{0};
  LatencyHistogram cycle_;
  LatencyHistogram response_;
  std::atomic<std::uint64_t> over_budget_{0};
  std::atomic<std::uint64_t> missed_deadline_{0};
  std::atomic<std::int64_t> cycle_max_at_ns_{0};
  std::atomic<std::int64_t> response_max_at_ns_{0};
};

}  // namespace rtm
