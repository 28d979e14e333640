// SPDX-License-Identifier: Apache-2.0
// Periodic activity lateness beside a bare clock_nanosleep loop, at 2 ms and 1 ms, both running
// at once in the same time window (the bare loop's deadlines half a period after the
// activity's, so neither delays the other's wake-up) with the same thread settings; then the
// mean period error of a long run (drift). Measured side by side, the ratio holds whatever
// else the machine does meanwhile; loops measured one after the other saw different machines.
//
//   rtm_bench_periodic [--seconds S] [--long-seconds L] [--fifo PRIO] [--cpu N]
//
// Lateness = wake time - deadline, on CLOCK_MONOTONIC. Both loops use absolute deadlines
// (TIMER_ABSTIME) and 1 ns timer slack; the activity's figures come from its own cycle
// context, recorded into a pre-allocated buffer.
#include "bench_stats.h"

#include "rt/activity.h"
#include "rtm/log.h"

#include <pthread.h>
#include <sched.h>
#include <sys/prctl.h>

#include <atomic>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>

namespace {

struct Settings {
  double seconds = 10;
  double long_seconds = 60;
  int fifo = 0;
  int cpu = -1;
};

struct Run {
  std::vector<std::int64_t> lateness_ns;
  double mean_period_error_ns = 0;
  std::uint64_t overruns = 0;
};

void apply_thread_settings(const Settings& s) {
  prctl(PR_SET_TIMERSLACK, 1UL, 0, 0, 0);
  if (s.fifo > 0) {
    sched_param param{};
    param.sched_priority = s.fifo;
    pthread_setschedparam(pthread_self(), SCHED_FIFO, &param);
  }
  if (s.cpu >= 0) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(s.cpu, &set);
    pthread_setaffinity_np(pthread_self(), sizeof(set), &set);
  }
}

// The bare loop on a thread of its own, first deadline at first_deadline_ns; join() it.
std::thread bare_loop(const Settings& s, std::int64_t period_ns, double seconds, std::int64_t first_deadline_ns,
                      Run& run) {
  const auto cycles = static_cast<std::size_t>(seconds * 1e9 / static_cast<double>(period_ns));
  run.lateness_ns.resize(cycles);
  return std::thread([&s, &run, cycles, period_ns, first_deadline_ns] {
    apply_thread_settings(s);
    std::int64_t deadline = first_deadline_ns;
    std::int64_t first_wake = 0, last_wake = 0;
    for (std::size_t i = 0; i < cycles; ++i) {
      timespec ts{static_cast<time_t>(deadline / 1'000'000'000), static_cast<long>(deadline % 1'000'000'000)};
      while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) != 0) {
      }
      const auto wake = rtm_bench::monotonic_ns();
      run.lateness_ns[i] = wake - deadline;
      if (run.lateness_ns[i] > period_ns) ++run.overruns;
      if (i == 0) first_wake = wake;
      last_wake = wake;
      deadline += period_ns;
    }
    run.mean_period_error_ns =
        static_cast<double>(last_wake - first_wake) / static_cast<double>(cycles - 1) - static_cast<double>(period_ns);
  });
}

// The activity; with a bare loop beside it (bare != nullptr) started half a period after its
// first wake-up, in the same window.
Run activity_loop(const Settings& s, std::int64_t period_ns, double seconds, Run* bare = nullptr) {
  Run run;
  const auto cycles = static_cast<std::size_t>(seconds * 1e9 / static_cast<double>(period_ns));
  run.lateness_ns.resize(cycles);
  std::atomic<bool> done{false};
  rtm::PeriodicOptions options;
  options.period_ns = period_ns;
  options.fifo_priority = s.fifo;
  options.cpu = s.cpu;
  options.thread_name = "bench-periodic";
  std::atomic<std::int64_t> first_deadline_ns{0};
  rtm::PeriodicActivity activity(
      [&](const rtm::CycleContext& ctx) {
        if (ctx.cycle == 0) first_deadline_ns.store(ctx.deadline_ns);
        if (ctx.cycle < cycles) run.lateness_ns[ctx.cycle] = ctx.wake_ns - ctx.deadline_ns;
        if (ctx.cycle + 1 >= cycles) {
          done.store(true);
          return false;
        }
        return true;
      },
      options);
  activity.start();
  std::thread beside;
  if (bare != nullptr) {
    while (first_deadline_ns.load() == 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    beside = bare_loop(s, period_ns, seconds, first_deadline_ns.load() + 2 * period_ns + period_ns / 2, *bare);
  }
  while (!done.load()) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  activity.stop();
  if (beside.joinable()) beside.join();
  const auto stats = activity.stats();
  run.mean_period_error_ns = stats.mean_period_error_ns;
  run.overruns = stats.overruns;
  return run;
}

void report(const char* label, Run& run) {
  auto s = rtm_bench::summarize(run.lateness_ns);
  rtm_bench::print_row(label, s);
  std::printf("%-44s mean period error %+.1f ns, overruns %llu\n", "", run.mean_period_error_ns,
              static_cast<unsigned long long>(run.overruns));
}

}  // namespace

int main(int argc, char** argv) {
  Settings s;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string key = argv[i];
    const char* value = argv[i + 1];
    if (key == "--seconds") s.seconds = std::atof(value);
    if (key == "--long-seconds") s.long_seconds = std::atof(value);
    if (key == "--fifo") s.fifo = std::atoi(value);
    if (key == "--cpu") s.cpu = std::atoi(value);
  }
  std::printf("periodic lateness, %.0f s per row, %s, %s\n", s.seconds,
              s.fifo > 0 ? ("SCHED_FIFO " + std::to_string(s.fifo)).c_str() : "SCHED_OTHER",
              s.cpu >= 0 ? ("CPU " + std::to_string(s.cpu)).c_str() : "unpinned");
  for (const std::int64_t period_ns : {2'000'000, 1'000'000}) {
    Run bare;
    auto activity = activity_loop(s, period_ns, s.seconds, &bare);
    const auto bare_label = "bare clock_nanosleep, " + std::to_string(period_ns / 1000) + " us";
    const auto activity_label = "rtm::PeriodicActivity, " + std::to_string(period_ns / 1000) + " us";
    report(bare_label.c_str(), bare);
    report(activity_label.c_str(), activity);
    const auto b = rtm_bench::summarize(bare.lateness_ns);
    const auto a = rtm_bench::summarize(activity.lateness_ns);
    std::printf("%-44s activity / bare, same window: p50 %.2f, p99 %.2f\n", "", a.p50_us / b.p50_us, a.p99_us / b.p99_us);
  }
  if (s.long_seconds > 0) {
    auto long_run = activity_loop(s, 2'000'000, s.long_seconds);
    const auto label = "rtm::PeriodicActivity, 2000 us, " + std::to_string(static_cast<int>(s.long_seconds)) + " s";
    report(label.c_str(), long_run);
  }
  return 0;
}
