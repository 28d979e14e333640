// SPDX-License-Identifier: Apache-2.0
#include "rt/thread.h"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace rtm {

namespace {

void to_stderr(const std::string& message) { std::fprintf(stderr, "rtm: warning: %s\n", message.c_str()); }

std::atomic<WarningSink> warning_sink{&to_stderr};

}  // namespace

void set_warning_sink(WarningSink sink) { warning_sink.store(sink ? sink : &to_stderr); }

void warn(const std::string& message) { warning_sink.load()(message); }

void set_thread_name(std::string_view name) {
  const std::string cut(name.substr(0, 15));
  pthread_setname_np(pthread_self(), cut.c_str());
}

namespace {

// struct sched_attr (linux/sched/types.h, size 48 since Linux 4.13), declared here: glibc has
// no sched_setattr() wrapper, and the kernel header clashes with <sched.h> on some systems.
struct SchedAttr {
  std::uint32_t size;
  std::uint32_t policy;
  std::uint64_t flags;
  std::int32_t nice;
  std::uint32_t priority;
  std::uint64_t runtime;
  std::uint64_t deadline;
  std::uint64_t period;
  std::uint32_t util_min;
  std::uint32_t util_max;
};

// Asks for a slice of slice_ns for a SCHED_OTHER thread, keeping its nice value; false (errno set)
// when the kernel refuses. Under any other policy it asks nothing and returns true.
bool request_slice(long slice_ns) {
  SchedAttr attr{};
  if (::syscall(SYS_sched_getattr, 0, &attr, sizeof attr, 0) != 0) return false;
  if (attr.policy != SCHED_OTHER) return true;
  attr.size = sizeof attr;
  attr.flags = 0;
  attr.runtime = static_cast<std::uint64_t>(slice_ns);
  return ::syscall(SYS_sched_setattr, 0, &attr, 0) == 0;
}

// SCHED_DEADLINE for the calling thread; false (errno set) when the kernel refuses.
bool request_deadline(std::int64_t runtime_ns, std::int64_t deadline_ns, std::int64_t period_ns) {
  SchedAttr attr{};
  attr.size = sizeof attr;
  attr.policy = 6;  // SCHED_DEADLINE: <sched.h> has no name for it
  attr.runtime = static_cast<std::uint64_t>(runtime_ns);
  attr.deadline = static_cast<std::uint64_t>(deadline_ns > 0 ? deadline_ns : period_ns);
  attr.period = static_cast<std::uint64_t>(period_ns);
  return ::syscall(SYS_sched_setattr, 0, &attr, 0) == 0;
}

}  // namespace

long current_slice_ns() {
  SchedAttr attr{};
  if (::syscall(SYS_sched_getattr, 0, &attr, sizeof attr, 0) != 0) return 0;
  return static_cast<long>(attr.runtime);
}

namespace {
std::atomic<int> g_path_thread_priority{0};
}  // namespace

void set_path_thread_priority(int fifo_priority) {
  if (fifo_priority < 0 || fifo_priority > 99)
    throw std::invalid_argument("path thread priority " + std::to_string(fifo_priority) + ": want 0..99");
  g_path_thread_priority.store(fifo_priority, std::memory_order_relaxed);
}

int path_thread_priority() { return g_path_thread_priority.load(std::memory_order_relaxed); }

int set_thread_fifo_priority(pthread_t thread, int fifo_priority) {
  sched_param param{};
  param.sched_priority = fifo_priority;
  return pthread_setschedparam(thread, fifo_priority > 0 ? SCHED_FIFO : SCHED_OTHER, &param);
}

void apply_thread_settings(const ThreadSettings& settings) {
  prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);
  if (!settings.name.empty()) set_thread_name(settings.name);
  const std::string who = settings.name.empty() ? std::string("thread") : settings.name;
  if (settings.cpu >= 0) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(settings.cpu, &set);
    if (int err = pthread_setaffinity_np(pthread_self(), sizeof(set), &set); err != 0)
      warn(who + ": cannot pin to CPU " + std::to_string(settings.cpu) + " (" + std::strerror(err) +
           "); running unpinned");
  }
  if (settings.fifo_priority > 0) {
    if (int err = set_thread_fifo_priority(pthread_self(), settings.fifo_priority); err != 0)
      warn(who + ": SCHED_FIFO priority " + std::to_string(settings.fifo_priority) + " refused (" +
           std::strerror(err) + "); running SCHED_OTHER" +
           (err == EPERM ? " (needs CAP_SYS_NICE or an rtprio limit)" : ""));
  }
  if (settings.deadline_runtime_ns > 0 &&
      !request_deadline(settings.deadline_runtime_ns, settings.deadline_ns, settings.deadline_period_ns)) {
    const int err = errno;
    warn(who + ": SCHED_DEADLINE reservation of " + std::to_string(settings.deadline_runtime_ns / 1000) + " us every " +
         std::to_string(settings.deadline_period_ns / 1000) + " us refused (" + std::strerror(err) +
         "); running SCHED_OTHER" +
         (err == EPERM ? " (needs CAP_SYS_NICE, and no CPU pinning)"
                       : err == EBUSY ? " (the kernel's admission test: the CPUs' deadline bandwidth is taken)" : ""));
  }
  if (settings.deadline_runtime_ns == 0 && settings.slice_ns > 0 && !request_slice(settings.slice_ns))
    warn(who + ": a time slice of " + std::to_string(settings.slice_ns / 1000) + " us refused (" +
         std::strerror(errno) + "); at SCHED_OTHER a waking cycle may wait for another thread's slice");
  if (settings.lock_memory && mlockall(MCL_CURRENT | MCL_FUTURE) != 0)
    warn(who + ": mlockall refused (" + std::strerror(errno) + "); page faults may delay cycles");
}

}  // namespace rtm
