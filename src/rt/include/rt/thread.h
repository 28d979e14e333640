// SPDX-License-Identifier: Apache-2.0
// Thread settings of a real-time loop, applied one way everywhere (activities of the core, the CAN master,
// the simulator). Each privileged setting that the system refuses is reported once through the warning sink
// and skipped: a developer machine without CAP_SYS_NICE still runs everything, only with worse timing.
#pragma once

#include <pthread.h>

#include <cstdint>
#include <string>
#include <string_view>

namespace rtm {

struct ThreadSettings {
  std::string name;        // pthread name, cut to 15 characters; "" keeps the current one
  int fifo_priority = 0;   // 1..99: SCHED_FIFO at that priority; 0: SCHED_OTHER
  int cpu = -1;            // pin the thread to this CPU; -1: no affinity
  bool lock_memory = false;  // mlockall(MCL_CURRENT | MCL_FUTURE)
  // At SCHED_OTHER: the time slice the thread asks for (sched_attr.sched_runtime of a fair
  // task; Linux 6.12 and later honour it, from 100 us, unprivileged; older kernels ignore it).
  // A loop with a short slice that wakes preempts the thread running its CPU instead of
  // waiting for that thread's slice to end. 0: the kernel's default slice.
  long slice_ns = 100'000;
  // SCHED_DEADLINE (instead of fifo_priority): a reservation of deadline_runtime_ns every
  // deadline_period_ns, due deadline_ns after each period's start (0: the period). The kernel
  // refuses it for a thread pinned to one CPU (cpu must be -1) and without CAP_SYS_NICE.
  std::int64_t deadline_runtime_ns = 0;  // 0: not SCHED_DEADLINE
  std::int64_t deadline_ns = 0;
  std::int64_t deadline_period_ns = 0;
};

// Applies settings to the calling thread, and a timer slack of 1 ns (the default 50 us makes
// SCHED_OTHER threads wake ~50 us late).
void apply_thread_settings(const ThreadSettings& settings);

// The calling thread's time slice as the kernel reports it (sched_attr.sched_runtime; Linux
// 6.12 and later), 0 where it reports none or the call fails.
long current_slice_ns();

// The SCHED_FIFO priority of the threads on the real-time path that are not an activity: the CAN listeners'
// receive threads, which hand a sensor's frames to its loop, and the core's delivery and ring-waiter threads.
// 0 (SCHED_OTHER) unless the process's runner set it, before building the component, from the real-time
// priority of its activity. Thread-safe.
void set_path_thread_priority(int fifo_priority);
int path_thread_priority();

// Puts `thread` at SCHED_FIFO fifo_priority (1..99), or back at SCHED_OTHER for 0; returns
// pthread_setschedparam's error (0 on success). For threads whose priority follows what they
// carry (a delivery thread, an ORB thread serving a put), set from outside or per request.
int set_thread_fifo_priority(pthread_t thread, int fifo_priority);

// Names the calling thread (cut to 15 characters).
void set_thread_name(std::string_view name);

// Where apply_thread_settings() reports a refused setting: stderr by default; the framework
// core routes it into its logger. Thread-safe.
using WarningSink = void (*)(const std::string& message);
void set_warning_sink(WarningSink sink);
void warn(const std::string& message);

}  // namespace rtm
