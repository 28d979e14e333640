// Activities: WHEN a component's cycle runs, kept apart from WHAT it computes.
//
// PeriodicActivity  own thread, absolute 2 ms (default) schedule on CLOCK_MONOTONIC
// OnArrivalActivity own thread, one cycle per arrival signalled by an InPort
// SharedTick        one periodic thread running several cycles in order (composites)
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "rtm/histogram.h"

namespace rtm {

// ============================ cycle context ===========================

// What a cycle knows about the moment it runs.
struct CycleContext {
  std::uint64_t cycle = 0;       // 0, 1, 2, ... since start()
  std::int64_t deadline_ns = 0;  // CLOCK_MONOTONIC: when this cycle was due (wake time for on-arrival)
  std::int64_t wake_ns = 0;      // CLOCK_MONOTONIC: when the thread actually woke
  std::int64_t period_ns = 0;    // nominal period; 0 for on-arrival
};

// One cycle. Returns false to stop the activity that runs it (e.g. the component failed).
using CycleFunction = std::function<bool(const CycleContext&)>;

// ============================ schedule arithmetic =====================

// The next deadline after a cycle due at deadline_ns finished at now_ns, on the grid
// deadline_ns + k * period_ns. A late cycle never shifts the grid: if the next deadline is
// less than one period in the past it is still taken (runs at once); if now_ns is more than
// one period past it, that cycle is an overrun and every missed deadline is skipped.
struct ScheduleStep {
  std::int64_t next_deadline_ns;  // CLOCK_MONOTONIC
  std::uint64_t skipped;          // deadlines dropped from the grid (0 unless overrun)
  bool overrun;
};
ScheduleStep next_deadline(std::int64_t deadline_ns, std::int64_t period_ns, std::int64_t now_ns);

// The first point of the grid origin_ns + k * period_ns (k any integer) at or after now_ns:
// how an activity joins another one's grid (e.g. the bus master's SYNC cycles) whenever it
// starts. period_ns > 0.
std::int64_t grid_point_at_or_after(std::int64_t origin_ns, std::int64_t period_ns, std::int64_t now_ns);

// A periodic activity's first deadline: now_ns when requested_ns is 0 (start at once),
// requested_ns when it is still ahead, otherwise the first point at or after now_ns on the grid
// requested_ns + k * period_ns (a start that came too late keeps the requested phase).
std::int64_t first_deadline(std::int64_t requested_ns, std::int64_t period_ns, std::int64_t now_ns);

// ============================ statistics ==============================

// A snapshot of an activity's timing (units in the names).
struct ActivityStats {
  std::int64_t period_ns = 0;
  std::uint64_t cycles = 0;
  std::uint64_t overruns = 0;     // cycles that woke, or ended, more than one period late
  std::uint64_t skipped = 0;      // deadlines skipped after overruns
  std::int64_t lateness_p50_ns = 0;  // wake - deadline; histogram bucket upper edge
  std::int64_t lateness_p99_ns = 0;
  std::int64_t lateness_max_ns = 0;  // exact
  double mean_period_error_ns = 0;   // mean(actual wake-to-wake interval - period_ns)
};

// ============================ activities ==============================

// Common control of every activity: start()/stop() are idempotent and safe from any thread;
// stop() returns once the thread has ended (when called from the activity's own thread, e.g.
// inside a cycle, it only requests the stop). stats() is safe while running.
class Activity {
 public:
  virtual ~Activity() = default;
  virtual void start() = 0;
  virtual void stop() = 0;
  virtual bool running() const = 0;
  virtual ActivityStats stats() const = 0;
};

// Thread settings of a periodic activity. Every privileged setting that fails with EPERM logs
// one warning and the activity runs without it.
struct PeriodicOptions {
  std::int64_t period_ns = 2'000'000;  // the PA10's 2 ms
  int fifo_priority = 0;               // 1..99: SCHED_FIFO at that priority; 0: SCHED_OTHER
  int cpu = -1;                        // pin the thread to this CPU; -1: no affinity
  bool lock_memory = false;            // mlockall(MCL_CURRENT | MCL_FUTURE) at start
  std::string thread_name = "rtm-periodic";  // pthread name, cut to 15 characters
  // CLOCK_MONOTONIC deadline of the first cycle, which fixes the phase of every later one (see
  // first_deadline()); 0: the first cycle runs at once.
  std::int64_t first_deadline_ns = 0;
};

// Runs cycle on an absolute schedule: clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME) to
// deadline, next deadline = deadline + period (see next_deadline()), timer slack 1 ns.
// Nothing in the loop allocates, locks or logs.
class PeriodicActivity final : public Activity {
 public:
  PeriodicActivity(CycleFunction cycle, PeriodicOptions options = {});
  ~PeriodicActivity() override;  // stop()
  void start() override;
  void stop() override;
  bool running() const override;
  ActivityStats stats() const override;
  const PeriodicOptions& options() const { return options_; }
  // Sets PeriodicOptions::first_deadline_ns for the next start(), e.g. from another activity's
  // grid known only then. Only while stopped: std::logic_error otherwise; std::invalid_argument
  // when negative.
  void set_first_deadline_ns(std::int64_t first_deadline_ns);

 private:
  void loop();
  CycleFunction cycle_;
  PeriodicOptions options_;
  mutable std::mutex control_mu_;  // serialises start()/stop()
  std::thread thread_;
  std::atomic<bool> stop_requested_{false};
  std::atomic<bool> running_{false};
  std::atomic<std::thread::id> own_thread_id_{};
  LatenessHistogram lateness_;
  std::atomic<std::uint64_t> cycles_{0};
  std::atomic<std::uint64_t> overruns_{0};
  std::atomic<std::uint64_t> skipped_{0};
  std::atomic<std::int64_t> period_error_sum_ns_{0};
  std::atomic<std::uint64_t> period_samples_{0};
};

// A counter an InPort bumps on every stored datum and an OnArrivalActivity waits on.
class ArrivalSignal {
 public:
  void notify();
  // Waits until the count differs from seen, *cancel becomes true, or timeout_ns passes;
  // updates seen. Returns true when something arrived.
  bool wait(std::uint64_t& seen, std::int64_t timeout_ns, const std::atomic<bool>* cancel = nullptr);
  // Wakes waiters so they re-check their cancel flag (count unchanged).
  void wake_waiters();
  std::uint64_t count() const;

 private:
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::uint64_t count_ = 0;
};

// Runs cycle once per wake-up by signal (arrivals close together may share one cycle, so a
// cycle reading a FIFO port should drain it).
class OnArrivalActivity final : public Activity {
 public:
  OnArrivalActivity(CycleFunction cycle, std::shared_ptr<ArrivalSignal> signal,
                    std::string thread_name = "rtm-arrival");
  ~OnArrivalActivity() override;
  void start() override;
  void stop() override;
  bool running() const override;
  ActivityStats stats() const override;  // cycles only

 private:
  void loop();
  CycleFunction cycle_;
  std::shared_ptr<ArrivalSignal> signal_;
  std::string thread_name_;
  mutable std::mutex control_mu_;
  std::thread thread_;
  std::atomic<bool> stop_requested_{false};
  std::atomic<bool> running_{false};
  std::atomic<std::thread::id> own_thread_id_{};
  std::atomic<std::uint64_t> cycles_{0};
};

// One periodic thread that runs several cycles in the order they were added, all in the same
// period (sensor -> controller -> actuator of a composite). When one returns false the rest
// of that cycle is skipped and the tick stops.
class SharedTick final : public Activity {
 public:
  explicit SharedTick(PeriodicOptions options = {});
  ~SharedTick() override;
  // Only while stopped; throws std::logic_error otherwise.
  void add(CycleFunction cycle);
  // See PeriodicActivity::set_first_deadline_ns.
  void set_first_deadline_ns(std::int64_t first_deadline_ns) { activity_.set_first_deadline_ns(first_deadline_ns); }
  const PeriodicOptions& options() const { return activity_.options(); }
  void start() override;
  void stop() override;
  bool running() const override;
  ActivityStats stats() const override;

 private:
  std::vector<CycleFunction> cycles_;
  PeriodicActivity activity_;
};

}  // namespace rtm
