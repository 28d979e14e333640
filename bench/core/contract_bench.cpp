// SPDX-License-Identifier: Apache-2.0
// Two figures of timing contracts (docs/timing.md), each measured side by side in one run:
//
//   rtm_bench_contract watch [--seconds S] [--rounds R] [--fifo PRIO] [--load "CMD"]
//     What watching costs: two identical components on 2 ms activities, 1 ms apart, one
//     watched against a contract and one not; which one is watched alternates every round.
//     Per side: wake-up lateness p99 (its activity's own figure) and CPU per cycle (the
//     activity thread's CPU time over its cycles), and the ratio watched / not.
//
//   rtm_bench_contract sched [--seconds S] [--rounds R] [--load "CMD"]
//     One 2 ms loop under each scheduling class at once, unpinned, 0.67 ms apart on one grid:
//     SCHED_OTHER, SCHED_FIFO 50, SCHED_DEADLINE 200 us every 2 ms due at its end (or
//     --dl-runtime-us, --dl-deadline-us). Lateness p50 / p99 / max and overruns of each.
//     SCHED_FIFO and SCHED_DEADLINE need root.
//
// --load "CMD" runs CMD (sh -c, its own process group, normal priority) for the whole run and
// stops it after: e.g. --load "cmake --build --preset asan -j2 --clean-first". Each cycle spins
// 20 us, a small component's work.
#include "rt/activity.h"
#include "rt/clock.h"
#include "rtm/component.h"

#include <signal.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace {

struct Settings {
  std::string mode;
  double seconds = 10;
  int rounds = 6;
  int fifo = 0;
  std::string load;
  std::int64_t dl_runtime_ns = 200'000;
  std::int64_t dl_deadline_ns = 2'000'000;
};

std::int64_t thread_cpu_ns() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

void spin_ns(std::int64_t ns) {
  const std::int64_t until = rtm::monotonic_ns() + ns;
  while (rtm::monotonic_ns() < until) {
  }
}

// A component whose cycle spins 20 us and notes its thread's CPU time at its first and last cycle.
class Worker final : public rtm::Component {
 public:
  explicit Worker(std::string name) : Component(std::move(name), "bench") {}
  void on_cycle(const rtm::CycleContext&) override {
    spin_ns(20'000);
    const std::int64_t cpu = thread_cpu_ns();
    if (cycles_.load(std::memory_order_relaxed) == 0) first_cpu_ns_ = cpu;
    last_cpu_ns_.store(cpu, std::memory_order_relaxed);
    cycles_.fetch_add(1, std::memory_order_relaxed);
  }
  // CPU per cycle between the first and the last, ns.
  double cpu_per_cycle_ns() const {
    const auto n = cycles_.load();
    return n > 1 ? static_cast<double>(last_cpu_ns_.load() - first_cpu_ns_) / static_cast<double>(n - 1) : 0;
  }

 private:
  std::atomic<std::uint64_t> cycles_{0};
  std::int64_t first_cpu_ns_ = 0;
  std::atomic<std::int64_t> last_cpu_ns_{0};
};

// A command at normal priority for the whole run (the machine's ordinary work).
class Load {
 public:
  explicit Load(const std::string& command) {
    if (command.empty()) return;
    pid_ = fork();
    if (pid_ == 0) {
      setpgid(0, 0);
      const sched_param other{};
      sched_setscheduler(0, SCHED_OTHER, &other);
      execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
      _exit(127);
    }
    setpgid(pid_, pid_);
  }
  ~Load() {
    if (pid_ <= 0) return;
    killpg(pid_, SIGTERM);
    waitpid(pid_, nullptr, 0);
  }
  Load(const Load&) = delete;
  Load& operator=(const Load&) = delete;

 private:
  pid_t pid_ = -1;
};

struct Side {
  double lateness_p99_us = 0;
  double cpu_per_cycle_us = 0;
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

int watch_cost(const Settings& s) {
  std::vector<double> watched_late, plain_late, watched_cpu, plain_cpu;
  std::printf("round  watched: late p99 us  cpu/cycle us   not: late p99 us  cpu/cycle us\n");
  for (int round = 0; round < s.rounds; ++round) {
    const bool first_watched = round % 2 == 0;
    std::vector<Side> sides(2);
    {
      std::vector<std::unique_ptr<rtm::ComponentServant>> servants;
      std::vector<Worker*> workers;
      const std::int64_t grid = (rtm::monotonic_ns() / 2'000'000 + 2) * 2'000'000;
      for (int k = 0; k < 2; ++k) {
        auto worker = std::make_unique<Worker>("worker" + std::to_string(k));
        workers.push_back(worker.get());
        rtm::PeriodicOptions o;
        o.fifo_priority = s.fifo;
        o.first_deadline_ns = grid + k * 1'000'000;
        o.thread_name = "worker" + std::to_string(k);
        auto servant = std::make_unique<rtm::ComponentServant>(std::move(worker), o);
        if ((k == 0) == first_watched) {
          rtm::TimingContract c;
          c.component = "worker" + std::to_string(k);
          c.budget_ns = 200'000;
          c.deadline_ns = 1'000'000;
          servant->watch_contract(c);
        }
        servants.push_back(std::move(servant));
      }
      for (auto& servant : servants) servant->on();
      std::this_thread::sleep_for(std::chrono::duration<double>(s.seconds));
      for (auto& servant : servants) servant->off();
      for (int k = 0; k < 2; ++k) {
        const RTM::TimingStats t = servants[k]->timing();
        sides[k] = {static_cast<double>(t.lateness_p99_ns) / 1e3, workers[k]->cpu_per_cycle_ns() / 1e3};
      }
    }
    const Side& w = sides[first_watched ? 0 : 1];
    const Side& p = sides[first_watched ? 1 : 0];
    watched_late.push_back(w.lateness_p99_us);
    plain_late.push_back(p.lateness_p99_us);
    watched_cpu.push_back(w.cpu_per_cycle_us);
    plain_cpu.push_back(p.cpu_per_cycle_us);
    std::printf("%5d  %20.1f  %12.2f  %16.1f  %12.2f\n", round + 1, w.lateness_p99_us, w.cpu_per_cycle_us,
                p.lateness_p99_us, p.cpu_per_cycle_us);
  }
  const double wl = median(watched_late), pl = median(plain_late), wc = median(watched_cpu), pc = median(plain_cpu);
  std::printf("median over %d rounds of %.0f s: lateness p99 %.1f vs %.1f us (%.3fx), CPU per cycle %.2f vs %.2f us "
              "(%.3fx; the cycle's own work is 20 us)\n",
              s.rounds, s.seconds, wl, pl, pl > 0 ? wl / pl : 0, wc, pc, pc > 0 ? wc / pc : 0);
  return 0;
}

int sched_classes(const Settings& s) {
  struct Class {
    std::string name;
    int fifo;
    std::int64_t runtime_ns;
  };
  const std::string dl_name = "SCHED_DEADLINE " + std::to_string(s.dl_runtime_ns / 1000) + "us/" +
                              std::to_string(s.dl_deadline_ns / 1000) + "us/2ms";
  const Class classes[] = {{"SCHED_OTHER", 0, 0}, {"SCHED_FIFO 50", 50, 0}, {dl_name.c_str(), 0, s.dl_runtime_ns}};
  std::printf("round  class                       late p50 us  late p99 us  late max us  overruns  cycles\n");
  for (int round = 0; round < s.rounds; ++round) {
    std::vector<std::unique_ptr<rtm::PeriodicActivity>> loops;
    const std::int64_t grid = (rtm::monotonic_ns() / 2'000'000 + 2) * 2'000'000;
    for (int k = 0; k < 3; ++k) {
      rtm::PeriodicOptions o;
      o.fifo_priority = classes[k].fifo;
      o.deadline_runtime_ns = classes[k].runtime_ns;
      o.deadline_ns = s.dl_deadline_ns;
      o.first_deadline_ns = grid + k * 666'667;
      o.thread_name = std::string("class") + std::to_string(k);
      loops.push_back(std::make_unique<rtm::PeriodicActivity>(
          [](const rtm::CycleContext&) {
            spin_ns(20'000);
            return true;
          },
          o));
    }
    for (auto& loop : loops) loop->start();
    std::this_thread::sleep_for(std::chrono::duration<double>(s.seconds));
    for (auto& loop : loops) loop->stop();
    for (int k = 0; k < 3; ++k) {
      const rtm::ActivityStats t = loops[k]->stats();
      std::printf("%5d  %-26s  %11.1f  %11.1f  %11.1f  %8llu  %6llu\n", round + 1, classes[k].name.c_str(), t.lateness_p50_ns / 1e3,
                  t.lateness_p99_ns / 1e3, t.lateness_max_ns / 1e3, static_cast<unsigned long long>(t.overruns),
                  static_cast<unsigned long long>(t.cycles));
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Settings s;
  if (argc > 1) s.mode = argv[1];
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string key = argv[i];
    if (key == "--seconds") s.seconds = std::atof(argv[i + 1]);
    else if (key == "--rounds") s.rounds = std::atoi(argv[i + 1]);
    else if (key == "--fifo") s.fifo = std::atoi(argv[i + 1]);
    else if (key == "--load") s.load = argv[i + 1];
    else if (key == "--dl-runtime-us") s.dl_runtime_ns = std::atoll(argv[i + 1]) * 1000;
    else if (key == "--dl-deadline-us") s.dl_deadline_ns = std::atoll(argv[i + 1]) * 1000;
    else {
      std::fprintf(stderr, "unknown option %s\n", key.c_str());
      return 2;
    }
  }
  if (s.mode != "watch" && s.mode != "sched") {
    std::fprintf(stderr, "usage: %s watch|sched [--seconds S] [--rounds R] [--fifo PRIO] [--load CMD]\n", argv[0]);
    return 2;
  }
  const Load load(s.load);
  return s.mode == "watch" ? watch_cost(s) : sched_classes(s);
}
