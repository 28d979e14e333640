// SPDX-License-Identifier: Apache-2.0
// The periodic schedule every loop of the project runs on: deadlines on a fixed grid of CLOCK_MONOTONIC, what
// a late cycle does to the grid, and the loop's timing statistics. PeriodicActivity sleeps on it
// (clock_nanosleep); pa10-sim's loop, which also waits for CAN frames between steps, drives it from ppoll.
#pragma once

#include <atomic>
#include <cstdint>
#include <optional>
#include <string_view>

#include "rt/histogram.h"

namespace rtm {

// ============================ schedule arithmetic =====================

// The next deadline after a cycle due at deadline_ns finished at now_ns, on the grid
// deadline_ns + k * period_ns. A late cycle never shifts the grid: if the next deadline is
// less than catch_up_ns in the past it is still taken (runs at once); if now_ns is catch_up_ns
// or more past it, that cycle is an overrun and every missed deadline is skipped.
// catch_up_ns 0 means one period (an activity: at most one cycle runs late, no burst).
struct ScheduleStep {
  std::int64_t next_deadline_ns;  // CLOCK_MONOTONIC
  std::uint64_t skipped;          // deadlines dropped from the grid (0 unless overrun)
  bool overrun;
};
ScheduleStep next_deadline(std::int64_t deadline_ns, std::int64_t period_ns, std::int64_t now_ns,
                           std::int64_t catch_up_ns = 0);

// The first point of the grid origin_ns + k * period_ns (k any integer) at or after now_ns: how an activity
// joins another one's grid (e.g. the bus master's SYNC cycles) whenever it starts. period_ns > 0.
std::int64_t grid_point_at_or_after(std::int64_t origin_ns, std::int64_t period_ns, std::int64_t now_ns);

// A periodic loop's first deadline: now_ns when requested_ns is 0 (start at once),
// requested_ns when it is still ahead, otherwise the first point at or after now_ns on the grid
// requested_ns + k * period_ns (a start that came too late keeps the requested phase).
std::int64_t first_deadline(std::int64_t requested_ns, std::int64_t period_ns, std::int64_t now_ns);

// A duration as "2ms", "500us", "250000ns", "0.002s" or "0.002" (seconds), in ns; nullopt when
// the text is none or not finite. Callers check the range they take.
std::optional<double> parse_duration_ns(std::string_view text);

// ============================ cycle context ===========================

// What a cycle knows about the moment it runs.
struct CycleContext {
  std::uint64_t cycle = 0;       // 0, 1, 2, ... since start
  std::int64_t deadline_ns = 0;  // CLOCK_MONOTONIC: when this cycle was due (wake time for on-arrival)
  std::int64_t wake_ns = 0;      // CLOCK_MONOTONIC: when the thread actually woke
  std::int64_t period_ns = 0;    // nominal period; 0 for on-arrival
};

// ============================ statistics ==============================

// A snapshot of a loop's timing (units in the names).
struct ActivityStats {
  std::int64_t period_ns = 0;
  std::uint64_t cycles = 0;
  std::uint64_t overruns = 0;     // cycles that woke more than a period late, or ended past the catch-up bound
  std::uint64_t skipped = 0;      // deadlines skipped after overruns
  std::int64_t lateness_p50_ns = 0;  // wake - deadline; histogram bucket upper edge
  std::int64_t lateness_p99_ns = 0;
  std::int64_t lateness_max_ns = 0;  // exact
  double mean_period_error_ns = 0;   // mean(actual wake-to-wake interval - period_ns)
};

// ============================ the schedule ============================

// One periodic loop's deadlines and statistics. The loop's thread calls start(), then per
// cycle: wait until deadline_ns(), begin(wake), run the cycle, end(now). stats() is safe from
// any thread meanwhile. Nothing allocates, locks or logs.
class PeriodicSchedule {
 public:
  // period_ns > 0; catch_up_ns as in next_deadline() (0: one period). std::invalid_argument otherwise.
  explicit PeriodicSchedule(std::int64_t period_ns, std::int64_t catch_up_ns = 0);

  // The first deadline from first_deadline(requested_ns, period, now_ns). Keeps the statistics
  // of earlier runs (a restarted activity counts on).
  void start(std::int64_t requested_first_ns, std::int64_t now_ns);
  // CLOCK_MONOTONIC deadline of the next cycle (readable from any thread).
  std::int64_t deadline_ns() const { return deadline_ns_.load(std::memory_order_relaxed); }
  std::int64_t period_ns() const { return period_ns_; }

  // The cycle due at deadline_ns() begins at wake_ns: records its lateness.
  CycleContext begin(std::int64_t wake_ns);
  // It ended at now_ns: the deadline moves on (next_deadline()), overruns and skips counted.
  void end(std::int64_t now_ns);

  ActivityStats stats() const;

 private:
  std::int64_t period_ns_;
  std::int64_t catch_up_ns_;
  std::atomic<std::int64_t> deadline_ns_{0};
  std::int64_t previous_wake_ns_ = -1;
  std::int64_t lateness_ns_ = 0;
  std::uint64_t previous_skipped_ = 0;
  std::uint64_t cycle_ = 0;
  LatenessHistogram lateness_;
  std::atomic<std::uint64_t> cycles_{0};
  std::atomic<std::uint64_t> overruns_{0};
  std::atomic<std::uint64_t> skipped_{0};
  std::atomic<std::int64_t> period_error_sum_ns_{0};
  std::atomic<std::uint64_t> period_samples_{0};
};

}  // namespace rtm
