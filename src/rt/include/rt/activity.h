// SPDX-License-Identifier: Apache-2.0
// Activities: WHEN a cycle runs, kept apart from WHAT it computes. CORBA-free: the core's
// components, the CAN master and the simulator run on them.
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

#include "rt/schedule.h"
#include "rt/thread.h"

namespace rtm {

// One cycle. Returns false to stop the activity that runs it (e.g. the component failed).
using CycleFunction = std::function<bool(const CycleContext&)>;

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
  // How far behind a late cycle may fall and its successors still run (at once, one after the
  // other) instead of being skipped; 0: one period (see next_deadline()).
  std::int64_t catch_up_ns = 0;
  // CLOCK_MONOTONIC deadline of the first cycle, which fixes the phase of every later one (see
  // first_deadline()); 0: the first cycle runs at once.
  std::int64_t first_deadline_ns = 0;

  // SCHED_DEADLINE instead of fifo_priority: a reservation of this runtime every period_ns, due
  // deadline_ns after each release (0: the period). 0: not SCHED_DEADLINE. See ThreadSettings.
  std::int64_t deadline_runtime_ns = 0;
  std::int64_t deadline_ns = 0;

  ThreadSettings thread_settings() const {
    ThreadSettings settings{thread_name, fifo_priority, cpu, lock_memory};
    settings.deadline_runtime_ns = deadline_runtime_ns;
    settings.deadline_ns = deadline_ns;
    settings.deadline_period_ns = period_ns;
    return settings;
  }
};

// Runs cycle on a PeriodicSchedule: clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME) to the deadline, next
// deadline = deadline + period (next_deadline()), timer slack 1 ns. The loop never allocates, locks or logs.
class PeriodicActivity final : public Activity {
 public:
  PeriodicActivity(CycleFunction cycle, PeriodicOptions options = {});
  ~PeriodicActivity() override;  // stop()
  void start() override;
  void stop() override;
  bool running() const override;
  ActivityStats stats() const override;
  const PeriodicOptions& options() const { return options_; }
  // Sets PeriodicOptions::first_deadline_ns for the next start(), e.g. from another activity's grid known
  // only then. Only while stopped: std::logic_error otherwise; std::invalid_argument when negative.
  void set_first_deadline_ns(std::int64_t first_deadline_ns);
  // The CLOCK_MONOTONIC deadline of the cycle the schedule runs next: while running, the one it
  // waits for or runs; once stopped, the first one it did not run (a stop() requested before a
  // deadline ends the activity without running that cycle). 0 before the first start().
  std::int64_t next_deadline_ns() const { return schedule_.deadline_ns(); }
  // Hands the grid over: the activity runs the cycle in progress, or else its next one, then ends; returns
  // the first deadline it did not run, about one period ahead, where another activity started with
  // set_first_deadline_ns() continues with no cycle lost or doubled. Waits at most one period plus a cycle.
  // While stopped: next_deadline_ns() at once. Not from the activity's own thread (std::logic_error).
  std::int64_t stop_after_cycle();

 private:
  void loop();
  CycleFunction cycle_;
  PeriodicOptions options_;
  mutable std::mutex control_mu_;  // serialises start()/stop()
  std::thread thread_;
  std::atomic<bool> stop_requested_{false};
  std::atomic<bool> stop_after_cycle_{false};
  std::atomic<bool> running_{false};
  std::atomic<std::thread::id> own_thread_id_{};
  PeriodicSchedule schedule_;
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
  void loop(std::uint64_t seen);  // seen: the signal's count when start() was called
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
