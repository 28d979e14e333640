// SPDX-License-Identifier: Apache-2.0
// Thread settings: what a refused privilege does, and that the settings reach the thread.
#include "rt/thread.h"

#include <gtest/gtest.h>
#include <pthread.h>
#include <sched.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/utsname.h>
#include <unistd.h>

#include <cstdio>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace {

std::mutex warnings_mu;
std::vector<std::string> warnings;
void record_warning(const std::string& message) {
  std::lock_guard lock(warnings_mu);
  warnings.push_back(message);
}

struct CapturedWarnings {
  CapturedWarnings() {
    std::lock_guard lock(warnings_mu);
    warnings.clear();
    rtm::set_warning_sink(&record_warning);
  }
  ~CapturedWarnings() { rtm::set_warning_sink(nullptr); }
  std::vector<std::string> taken() {
    std::lock_guard lock(warnings_mu);
    return warnings;
  }
};

TEST(ThreadSettings, NameAndTimerSlackReachTheCallingThread) {
  CapturedWarnings captured;
  std::string name;
  long slack = -1;
  std::thread([&] {
    rtm::apply_thread_settings(rtm::ThreadSettings{"rt-settings-test-long-name"});
    char buffer[32] = {};
    pthread_getname_np(pthread_self(), buffer, sizeof buffer);
    name = buffer;
    slack = prctl(PR_GET_TIMERSLACK, 0, 0, 0, 0);
  }).join();
  EXPECT_EQ(name, "rt-settings-tes") << "cut to the 15 characters Linux keeps";
  EXPECT_EQ(slack, 1);
  EXPECT_TRUE(captured.taken().empty());
}

TEST(ThreadSettings, AnUnavailableCpuIsAWarningNamingTheThreadNotAFailure) {
  CapturedWarnings captured;
  const int cpus = static_cast<int>(std::thread::hardware_concurrency());
  std::thread([&] {
    rtm::ThreadSettings settings{"pinned"};
    settings.cpu = cpus + 1000;  // no such CPU
    rtm::apply_thread_settings(settings);
  }).join();
  const auto taken = captured.taken();
  ASSERT_EQ(taken.size(), 1u);
  EXPECT_NE(taken[0].find("pinned: cannot pin to CPU"), std::string::npos) << taken[0];
}

TEST(ThreadSettings, FifoPriorityIsGrantedOrRefusedWithAWarningNeverSilently) {
  CapturedWarnings captured;
  int policy = -1;
  std::thread([&] {
    rtm::ThreadSettings settings{"fifo"};
    settings.fifo_priority = 10;
    rtm::apply_thread_settings(settings);
    sched_param param{};
    pthread_getschedparam(pthread_self(), &policy, &param);
  }).join();
  const auto taken = captured.taken();
  if (policy == SCHED_FIFO) {
    EXPECT_TRUE(taken.empty());
  } else {
    ASSERT_EQ(taken.size(), 1u) << "running without the priority asked for must be reported";
    EXPECT_NE(taken[0].find("SCHED_FIFO priority 10 refused"), std::string::npos) << taken[0];
  }
}

TEST(ThreadSettings, ASchedDeadlineReservationReachesTheThreadOrIsRefusedWithAWarningNeverSilently) {
  CapturedWarnings captured;
  int policy = -1;
  std::thread([&] {
    rtm::ThreadSettings settings{"reserved"};
    settings.deadline_runtime_ns = 100'000;
    settings.deadline_period_ns = 2'000'000;
    rtm::apply_thread_settings(settings);
    policy = sched_getscheduler(0);
  }).join();
  const auto taken = captured.taken();
  constexpr int kSchedDeadline = 6;
  if (policy == kSchedDeadline) {
    EXPECT_TRUE(taken.empty());
  } else {
    EXPECT_EQ(policy, SCHED_OTHER) << "refused, it runs as before";
    ASSERT_EQ(taken.size(), 1u) << "running without the reservation asked for must be reported";
    EXPECT_NE(taken[0].find("SCHED_DEADLINE reservation of 100 us every 2000 us refused"), std::string::npos)
        << taken[0];
  }
}

TEST(ThreadSettings, ASchedDeadlineReservationOnAPinnedThreadIsRefusedByTheKernelWithAWarning) {
  if (sysconf(_SC_NPROCESSORS_ONLN) < 2) GTEST_SKIP() << "one CPU: pinning spans the whole machine";
  CapturedWarnings captured;
  int policy = -1;
  std::thread([&] {
    rtm::ThreadSettings settings{"pinned"};
    settings.cpu = 0;
    settings.deadline_runtime_ns = 100'000;
    settings.deadline_period_ns = 2'000'000;
    rtm::apply_thread_settings(settings);
    policy = sched_getscheduler(0);
  }).join();
  EXPECT_EQ(policy, SCHED_OTHER);
  const auto taken = captured.taken();
  ASSERT_FALSE(taken.empty());
  EXPECT_NE(taken.back().find("SCHED_DEADLINE reservation of 100 us every 2000 us refused"), std::string::npos)
      << taken.back();
}

// Linux 6.12 and later keep a fair task's own slice; older kernels take the request and
// ignore it (the loops then wait out other threads' slices, as before).
bool kernel_keeps_fair_slices(std::string& release) {
  utsname u{};
  if (uname(&u) != 0) return false;
  release = u.release;
  int major = 0, minor = 0;
  if (std::sscanf(u.release, "%d.%d", &major, &minor) != 2) return false;
  return major > 6 || (major == 6 && minor >= 12);
}

TEST(ThreadSettings, AtSchedOtherTheThreadGetsTheShortSliceItAsksForAndKeepsItsNiceValue) {
  std::string release;
  if (!kernel_keeps_fair_slices(release)) GTEST_SKIP() << "Linux " << release << " ignores a fair task's slice";
  CapturedWarnings captured;
  long slice = -1;
  int nice_after = 0;
  std::thread([&] {
    setpriority(PRIO_PROCESS, static_cast<id_t>(gettid()), 3);
    rtm::ThreadSettings settings{"sliced"};
    settings.slice_ns = 250'000;
    rtm::apply_thread_settings(settings);
    slice = rtm::current_slice_ns();
    nice_after = getpriority(PRIO_PROCESS, static_cast<id_t>(gettid()));
  }).join();
  EXPECT_EQ(slice, 250'000);
  EXPECT_EQ(nice_after, 3) << "asking for a slice reset the thread's nice value";
  EXPECT_TRUE(captured.taken().empty());
}

TEST(ThreadSettings, TheDefaultSliceOfALoopIsTheKernelsShortest) {
  std::string release;
  if (!kernel_keeps_fair_slices(release)) GTEST_SKIP() << "Linux " << release << " ignores a fair task's slice";
  long slice = -1;
  std::thread([&] {
    rtm::apply_thread_settings(rtm::ThreadSettings{"loop"});
    slice = rtm::current_slice_ns();
  }).join();
  EXPECT_EQ(slice, 100'000);
}

}  // namespace
