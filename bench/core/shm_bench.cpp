// SPDX-License-Identifier: Apache-2.0
// The shared-memory ring between two processes (rt/shm_ring.h, in a ShmSegment), each figure
// beside its bare floor measured in the same run, in alternating slices:
//   visible     a reader polling the ring sees a datum this long after the writer stamped it
//               (just before write()); floor: the same stamp through one shared atomic.
//   wake        an on-arrival reader blocked in wait_for_data() runs this long after the
//               stamp; floor: a bare futex wake of a process blocked in FUTEX_WAIT.
//   periodic    a reader taking data in its own 1 ms cycle: context switches per datum beyond
//               its cycle's own sleep (0: the datum costs the reader no switch).
//   throughput  a writer writing 32-byte data back to back, a reader taking each in order:
//               data taken per second, and missed; floor: the writer alone.
// The writer is a child process (fork); this process is the reader.
//
//   rtm_bench_shm [--samples N] [--slices S] [--pin none|split|same|all] [--neighbour none|busy]
//
// --neighbour busy: a process keeps one CPU busy (a spinning loop at normal priority) for
// the whole run, as another program on the machine would.
// --pin: none lets the scheduler place both processes; split puts the writer on CPU 0 and
// the reader on CPU 1; same puts both on CPU 0 (wake rows only: a polling reader on the
// writer's CPU starves it). all (default): each row unpinned, then pinned.
#include "bench_stats.h"
#include "busy_neighbour.h"

#include "rt/shm_ring.h"
#include "rt/shm_segment.h"

#include <linux/futex.h>
#include <sched.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <climits>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace {

using rtm_bench::monotonic_ns;

constexpr std::uint64_t kType = 0x7E57;

struct Datum {  // the size of an RTM::TimedFloat6
  std::int64_t stamp_ns;
  float values[6];
};
static_assert(sizeof(Datum) == 32);

// Control and the floors' words, in an anonymous shared mapping both processes see.
struct Shared {
  alignas(64) std::atomic<std::int64_t> bare_stamp{0};
  alignas(64) std::atomic<std::uint32_t> bare_futex{0};
  std::atomic<std::int64_t> bare_futex_stamp{0};
  alignas(64) std::atomic<int> reader_ready{0};
  std::atomic<int> stop{0};
};

// Pins the calling process to cpu; -1: any CPU again.
void pin(int cpu) {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (cpu >= 0) CPU_SET(cpu, &set);
  else
    for (long c = 0; c < sysconf(_SC_NPROCESSORS_ONLN); ++c) CPU_SET(c, &set);
  sched_setaffinity(0, sizeof(set), &set);
}

void sleep_until(std::int64_t t_ns) {
  const timespec ts{static_cast<time_t>(t_ns / 1'000'000'000), static_cast<long>(t_ns % 1'000'000'000)};
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

long futex(std::atomic<std::uint32_t>* word, int op, std::uint32_t value) {
  return syscall(SYS_futex, reinterpret_cast<std::uint32_t*>(word), op, value, nullptr, nullptr, 0);
}

long switches() {
  rusage u{};
  getrusage(RUSAGE_THREAD, &u);
  return u.ru_nvcsw + u.ru_nivcsw;
}

// Runs body in a child process on cpu; returns its pid.
pid_t spawn(int cpu, const std::function<void()>& body) {
  const pid_t pid = fork();
  if (pid == 0) {
    pin(cpu);
    body();
    _exit(0);
  }
  return pid;
}

void reap(pid_t pid) { waitpid(pid, nullptr, 0); }

struct Placement {
  const char* name;
  int writer_cpu;
  int reader_cpu;
};

// A ring laid out by this process; the writer child writes through its copy of `writer`.
struct Ring {
  rtm::ShmSegment segment;
  rtm::ShmRingWriter writer;
  explicit Ring(std::uint32_t slots)
      : segment(rtm::ShmSegment::create(rtm::shm_ring_bytes({slots, sizeof(Datum), kType}), "bench")),
        writer(segment.data(), segment.size(), {slots, sizeof(Datum), kType}) {}
};

// ---- visible: a polling reader ------------------------------------------------------------

void visible_slice(Shared& sh, const Placement& at, bool bare, std::size_t n, std::vector<std::int64_t>& out) {
  Ring ring(8);
  rtm::ShmRingReader reader(ring.segment.data(), ring.segment.size(), kType);
  sh.bare_stamp = 0;
  sh.stop = 0;
  pin(at.reader_cpu);
  const pid_t writer = spawn(at.writer_cpu, [&] {
      auto& w = ring.writer;
    Datum d{};
    std::int64_t next = monotonic_ns() + 1'000'000;
    for (std::size_t i = 0; i < n; ++i, next += 200'000) {
      sleep_until(next);
      d.stamp_ns = monotonic_ns();
      if (bare) sh.bare_stamp.store(d.stamp_ns, std::memory_order_release);
      else w.write(std::as_bytes(std::span(&d, 1)));
    }
    sh.stop.store(1, std::memory_order_release);
  });
  // Until the writer is done: a reader that was preempted for longer than a period misses a
  // datum (it only ever takes the latest), so the samples may be fewer than n.
  Datum d{};
  std::int64_t last = 0;
  for (;;) {
    const bool done = sh.stop.load(std::memory_order_acquire);
    std::int64_t stamp = 0;
    if (bare) {
      stamp = sh.bare_stamp.load(std::memory_order_acquire);
    } else if (reader.take_latest(std::as_writable_bytes(std::span(&d, 1))).status == rtm::ReadStatus::new_data) {
      stamp = d.stamp_ns;
    }
    if (stamp != 0 && stamp != last) {
      out.push_back(monotonic_ns() - stamp);
      last = stamp;
    } else if (done) {
      break;
    }
  }
  reap(writer);
}

// ---- wake: an on-arrival reader -----------------------------------------------------------

void wake_slice(Shared& sh, const Placement& at, bool bare, std::size_t n, std::vector<std::int64_t>& out,
                long& switches_used) {
  Ring ring(8);
  rtm::ShmRingReader reader(ring.segment.data(), ring.segment.size(), kType);
  sh.bare_futex = 0;
  sh.reader_ready = 0;
  pin(at.reader_cpu);
  const pid_t writer = spawn(at.writer_cpu, [&] {
      auto& w = ring.writer;
    while (sh.reader_ready.load() == 0) sched_yield();
    Datum d{};
    std::int64_t next = monotonic_ns() + 2'000'000;
    for (std::size_t i = 0; i < n; ++i, next += 1'000'000) {
      sleep_until(next);
      d.stamp_ns = monotonic_ns();
      if (bare) {
        sh.bare_futex_stamp.store(d.stamp_ns, std::memory_order_relaxed);
        sh.bare_futex.fetch_add(1, std::memory_order_release);
        futex(&sh.bare_futex, FUTEX_WAKE, INT_MAX);
      } else {
        w.write(std::as_bytes(std::span(&d, 1)));
      }
    }
  });
  const long before = switches();
  sh.reader_ready = 1;
  Datum d{};
  std::uint32_t seen = 0;
  for (std::size_t got = 0; got < n;) {
    if (bare) {
      const std::uint32_t now = sh.bare_futex.load(std::memory_order_acquire);
      if (now == seen) {
        futex(&sh.bare_futex, FUTEX_WAIT, seen);
        continue;
      }
      out.push_back(monotonic_ns() - sh.bare_futex_stamp.load(std::memory_order_relaxed));
      got += now - seen - 1;  // writes seen at once (the reader was late): one sample, the latest
      seen = now;
    } else {
      reader.wait_for_data(rtm::ShmRingReader::kNoDeadline);
      const auto r = reader.take_next(std::as_writable_bytes(std::span(&d, 1)));
      out.push_back(monotonic_ns() - d.stamp_ns);
      got += r.missed;  // a reader stalled for more than a ring's worth of data
    }
    ++got;
  }
  switches_used += switches() - before;
  reap(writer);
}

// ---- periodic: a reader in its own cycle ------------------------------------------------------

void periodic_row(const Placement& at, std::size_t n) {
  Ring ring(8);
  rtm::ShmRingReader reader(ring.segment.data(), ring.segment.size(), kType);
  pin(at.reader_cpu);
  const std::int64_t start = monotonic_ns() + 5'000'000;
  const pid_t writer = spawn(at.writer_cpu, [&] {
      auto& w = ring.writer;
    Datum d{};
    for (std::size_t i = 0; i < n; ++i) {  // half a period before each of the reader's cycles
      sleep_until(start + static_cast<std::int64_t>(i) * 1'000'000 - 500'000);
      d.stamp_ns = monotonic_ns();
      w.write(std::as_bytes(std::span(&d, 1)));
    }
  });
  std::vector<std::int64_t> age;
  Datum d{};
  std::size_t data = 0, cycles = 0;
  sleep_until(start - 1'000'000);
  const long before = switches();
  for (std::size_t i = 0; i < n; ++i, ++cycles) {
    sleep_until(start + static_cast<std::int64_t>(i) * 1'000'000);
    while (reader.take_next(std::as_writable_bytes(std::span(&d, 1))).status == rtm::ReadStatus::new_data) {
      age.push_back(monotonic_ns() - d.stamp_ns);
      ++data;
    }
  }
  const long used = switches() - before;
  reap(writer);
  const auto s = rtm_bench::summarize(age);
  // The cycle's own sleep is at most one switch per cycle (none when a deadline had passed):
  // switches beyond that are what the data cost.
  const long beyond = used > static_cast<long>(cycles) ? used - static_cast<long>(cycles) : 0;
  std::printf("periodic [%s]: %zu data in %zu cycles of 1 ms: %ld switches (%.3f per cycle), %ld beyond one per "
              "cycle = %.3f per datum; age when taken p50 %.1f us (half a period by design)\n",
              at.name, data, cycles, used, cycles ? static_cast<double>(used) / static_cast<double>(cycles) : 0.0,
              beyond, data ? static_cast<double>(beyond) / static_cast<double>(data) : 0.0, s.p50_us);
}

// ---- throughput -----------------------------------------------------------------------------

void throughput_row(Shared& sh, const Placement& at, double seconds) {
  constexpr std::uint32_t kSlots = 1024;
  auto run_writer = [&](Ring& ring, bool with_reader) {
    sh.stop = 0;
    sh.reader_ready = with_reader ? 0 : 1;
    return spawn(at.writer_cpu, [&] {
      auto& w = ring.writer;
      while (sh.reader_ready.load() == 0) sched_yield();
      Datum d{};
      const std::int64_t end = monotonic_ns() + static_cast<std::int64_t>(seconds * 1e9);
      for (std::int64_t i = 0;; ++i) {
        d.stamp_ns = i;
        w.write(std::as_bytes(std::span(&d, 1)));
        if ((i & 1023) == 0 && monotonic_ns() >= end) break;
      }
      sh.bare_stamp.store(static_cast<std::int64_t>(w.written()));
      sh.stop = 1;
    });
  };
  // Floor: the writer alone.
  sh.bare_stamp = 0;
  {
    Ring alone_ring(kSlots);
    reap(run_writer(alone_ring, false));
  }
  const double alone = static_cast<double>(sh.bare_stamp.load()) / seconds;
  pin(at.reader_cpu);
  Ring ring(kSlots);
  rtm::ShmRingReader fresh(ring.segment.data(), ring.segment.size(), kType);
  const pid_t writer = run_writer(ring, true);
  Datum d{};
  std::uint64_t taken = 0, missed = 0;
  sh.reader_ready = 1;
  for (;;) {
    const bool stopped = sh.stop.load(std::memory_order_acquire);  // before the read: then all is in
    const auto r = fresh.take_next(std::as_writable_bytes(std::span(&d, 1)));
    missed += r.missed;
    if (r.status == rtm::ReadStatus::new_data) ++taken;
    else if (stopped) break;
  }
  reap(writer);
  const double written = static_cast<double>(sh.bare_stamp.load());
  std::printf("throughput [%s]: writer alone %.2f M/s; with a reader: written %.2f M/s, taken %.2f M/s, "
              "missed %.2f %%\n",
              at.name, alone / 1e6, written / seconds / 1e6, static_cast<double>(taken) / seconds / 1e6,
              written > 0 ? 100.0 * static_cast<double>(missed) / written : 0.0);
}

}  // namespace

int main(int argc, char** argv) {
  std::map<std::string, std::string> args;
  for (int i = 1; i + 1 < argc; i += 2) args[argv[i]] = argv[i + 1];
  auto get = [&](const std::string& k, const std::string& d) { return args.count(k) ? args[k] : d; };
  const auto samples = static_cast<std::size_t>(std::stol(get("--samples", "2000")));
  const int slices = std::stoi(get("--slices", "10"));
  const std::string pin_mode = get("--pin", "all");
  void* memory = mmap(nullptr, sizeof(Shared), PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
  if (memory == MAP_FAILED) return 1;
  auto& sh = *new (memory) Shared{};
  std::optional<rtm_bench::BusyNeighbour> neighbour;
  if (get("--neighbour", "none") == "busy") neighbour.emplace();
  const Placement none{"unpinned", -1, -1}, split{"writer CPU 0, reader CPU 1", 0, 1},
      same{"both on CPU 0", 0, 0};
  const bool all = pin_mode == "all";
  std::vector<Placement> spin_places, wake_places;
  if (all || pin_mode == "none") spin_places.push_back(none), wake_places.push_back(none);
  if (all || pin_mode == "split") spin_places.push_back(split), wake_places.push_back(split);
  if (all || pin_mode == "same") wake_places.push_back(same);
  const std::size_t per_slice = samples / static_cast<std::size_t>(slices);
  for (const auto& at : spin_places) {
    std::vector<std::int64_t> ring_ns, bare_ns;
    for (int s = 0; s < slices; ++s) {
      for (const bool bare : {s % 2 == 1, s % 2 == 0}) visible_slice(sh, at, bare, per_slice, bare ? bare_ns : ring_ns);
    }
    std::printf("visible [%s]:\n", at.name);
    rtm_bench::print_row("  ring: take_latest sees the datum", rtm_bench::summarize(ring_ns));
    rtm_bench::print_row("  floor: one shared atomic", rtm_bench::summarize(bare_ns));
  }
  for (const auto& at : wake_places) {
    std::vector<std::int64_t> ring_ns, bare_ns;
    long ring_sw = 0, bare_sw = 0;
    for (int s = 0; s < slices; ++s) {  // which goes first alternates too
      for (const bool bare : {s % 2 == 1, s % 2 == 0}) {
        if (bare) wake_slice(sh, at, true, per_slice, bare_ns, bare_sw);
        else wake_slice(sh, at, false, per_slice, ring_ns, ring_sw);
      }
    }
    const double n = static_cast<double>(per_slice) * slices;
    std::printf("wake [%s]: switches per datum: ring %.2f, bare futex %.2f\n", at.name, ring_sw / n, bare_sw / n);
    const auto r = rtm_bench::summarize(ring_ns), b = rtm_bench::summarize(bare_ns);
    rtm_bench::print_row("  ring: wait_for_data returns", r);
    rtm_bench::print_row("  floor: bare futex wake", b);
    std::printf("  ratio ring / floor: p50 %.2f, p99 %.2f\n", r.p50_us / b.p50_us, r.p99_us / b.p99_us);
  }
  for (const auto& at : spin_places) periodic_row(at, samples);
  for (const auto& at : spin_places) throughput_row(sh, at, 1.0);
  return 0;
}
