// SPDX-License-Identifier: Apache-2.0
// Frames through a CAN transport, and the master's lock-step cycle against pa10-sim's CAN nodes
// on a kinematic plant (tests/support/rtm_test/can/emulated_pa10.h).
//
// usage: can_transport_bench [BUS]   BUS = "local" (default: starts its own hub in a temporary
//        directory) or a spec such as "socketcan:vcan0" (run in a QEMU guest with
//        scripts/vm-vcan-run; the guest is not real-time: its figures are functional only).
// Prints: one-way burst throughput (frames/s), ping-pong round trip (p50/p99/max), a cycle's
// 8 frames written by 8 send() calls vs one send_batch(), and the lock-step master cycle
// (RPDOs + SYNC + 7 drive and 4 sensor TPDOs) rate.
#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "arm/can/bus.h"
#include "arm/can/local_bus.h"
#include "arm/can/master.h"
#include "rtm_test/can/emulated_pa10.h"

namespace {

using namespace rtm::can;
using Clock = std::chrono::steady_clock;

double cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec) / 1e6;
}

struct Percentiles {
  double p50_us, p99_us, max_us;
};
Percentiles percentiles(std::vector<double>& samples_us) {
  std::sort(samples_us.begin(), samples_us.end());
  auto at = [&](double q) { return samples_us[static_cast<std::size_t>(q * static_cast<double>(samples_us.size() - 1))]; };
  return {at(0.5), at(0.99), samples_us.back()};
}

// Sustained one-way throughput: the sender keeps at most kWindow frames in flight, so the
// figure is what the transport carries without dropping (the hub drops rather than block).
void burst(const std::string& spec) {
  auto tx = open_bus(spec);
  auto rx = open_bus(spec);
  constexpr int kFrames = 200000;
  constexpr int kWindow = 64;
  std::atomic<int> received{0};
  std::atomic<bool> sender_done{false};
  std::thread reader([&] {
    can_frame f{};
    while (received.load(std::memory_order_relaxed) < kFrames) {
      if (rx->receive(f, 200'000'000)) {
        received.fetch_add(1, std::memory_order_release);
      } else if (sender_done.load()) {
        break;  // the rest was dropped
      }
    }
  });
  can_frame f{};
  f.can_id = 0x181;
  f.can_dlc = 8;
  int full = 0;
  const double cpu0 = cpu_seconds();
  const auto t0 = Clock::now();
  for (int i = 0; i < kFrames; ++i) {
    while (i - received.load(std::memory_order_acquire) >= kWindow) std::this_thread::yield();
    f.data[0] = static_cast<std::uint8_t>(i);
    while (!tx->send(f)) {  // queue full: let the hub run
      ++full;
      std::this_thread::yield();
    }
  }
  sender_done = true;
  while (received.load() < kFrames && Clock::now() - t0 < std::chrono::seconds(60)) {
    std::this_thread::yield();
  }
  const double s = std::chrono::duration<double>(Clock::now() - t0).count();
  reader.join();
  const double cpu = cpu_seconds() - cpu0;
  std::printf("stream  %-22s %d of %d frames in %.3f s: %.0f frames/s (CPU %.2f us/frame, "
              "window %d, send queue full %d times)\n",
              spec.c_str(), received.load(), kFrames, s, received.load() / s,
              cpu / received.load() * 1e6, kWindow, full);
}

void ping_pong(const std::string& spec) {
  auto a = open_bus(spec);
  auto b = open_bus(spec);
  constexpr int kRounds = 20000;
  std::thread echo([&] {
    can_frame f{};
    for (int i = 0; i < kRounds; ++i) {
      if (!b->receive(f, 2'000'000'000)) return;
      f.can_id = 0x201;
      b->send(f);
    }
  });
  std::vector<double> rtt_us;
  rtt_us.reserve(kRounds);
  can_frame f{};
  f.can_dlc = 6;
  for (int i = 0; i < kRounds; ++i) {
    f.can_id = 0x181;
    const auto t0 = Clock::now();
    a->send(f);
    if (!a->receive(f, 2'000'000'000)) break;
    rtt_us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  echo.join();
  const auto p = percentiles(rtt_us);
  std::printf("rtt     %-22s n=%zu round trip p50 %.1f us, p99 %.1f us, max %.1f us\n", spec.c_str(),
              rtt_us.size(), p.p50_us, p.p99_us, p.max_us);
}

// Puts the calling thread on `cpu` at SCHED_FIFO `priority`; false when not allowed.
bool realtime_on(int cpu, int priority) {
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  sched_param param{};
  param.sched_priority = priority;
  return pthread_setaffinity_np(pthread_self(), sizeof set, &set) == 0 &&
         pthread_setschedparam(pthread_self(), SCHED_FIFO, &param) == 0;
}

// One cycle's frames (7 RPDOs + SYNC) handed to the bus: eight send() calls against one
// send_batch(), alternating in one run, with a reader draining the other end. The figure is
// the sender's time in the calls: what the cycle spends before its command has left.
// contended: the reader runs at a higher SCHED_FIFO priority on the sender's CPU, as a
// simulator or another node's process can (pa10-sim's hub at 30 against the servo at 20).
void cycle_write(const std::string& spec, bool contended) {
  auto tx = open_bus(spec);
  auto rx = open_bus(spec);
  std::atomic<bool> done{false};
  std::atomic<int> ready{0};
  std::thread reader([&] {
    if (contended && !realtime_on(0, 30)) {
      ready.store(-1);
      return;
    }
    ready.store(1);
    can_frame f{};
    while (!done.load(std::memory_order_relaxed)) rx->receive(f, 20'000'000);
  });
  while (ready.load() == 0) std::this_thread::yield();
  if (ready.load() < 0 || (contended && !realtime_on(0, 20))) {
    done.store(true);
    reader.join();
    std::printf("cycle   %-22s contended: skipped (SCHED_FIFO not allowed)\n", spec.c_str());
    return;
  }
  std::array<can_frame, 8> frames{};
  for (std::size_t i = 0; i < frames.size(); ++i) {
    frames[i].can_id = i < 7 ? static_cast<canid_t>(0x201 + i) : 0x080;
    frames[i].can_dlc = i < 7 ? 6 : 1;
  }
  constexpr int kRounds = 5000;
  std::vector<double> single_us, batch_us;
  single_us.reserve(kRounds);
  batch_us.reserve(kRounds);
  for (int i = 0; i < kRounds; ++i) {
    auto t0 = Clock::now();
    for (const auto& f : frames) tx->send(f);
    single_us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
    std::this_thread::sleep_for(std::chrono::microseconds(500));  // the receivers go back to sleep
    t0 = Clock::now();
    tx->send_batch(frames);
    batch_us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
    std::this_thread::sleep_for(std::chrono::microseconds(500));
  }
  done.store(true);
  reader.join();
  if (contended) {  // back to normal for the rest of the run
    sched_param normal{};
    pthread_setschedparam(pthread_self(), SCHED_OTHER, &normal);
  }
  const auto s = percentiles(single_us);
  const auto b = percentiles(batch_us);
  std::printf("cycle   %-22s %s7 RPDOs + SYNC, n=%d: 8 x send p50 %.1f us, p99 %.1f us, max %.1f us; "
              "send_batch p50 %.1f us, p99 %.1f us, max %.1f us\n",
              spec.c_str(), contended ? "contended, " : "", kRounds, s.p50_us, s.p99_us, s.max_us, b.p50_us,
              b.p99_us, b.max_us);
}

void lock_step(const std::string& spec) {
  MasterConfig config;
  config.heartbeat_timeout_ns = 5'000'000'000;
  config.enable_timeout_ns = 10'000'000'000;
  config.target_expiry_periods = 0;  // one target for all lock-step cycles
  Pa10Master master(open_bus(spec), nullptr, config);
  testing::EmulatedPa10 nodes(spec);
  master.start();
  master.set_target_velocities({0.01, 0.01, 0.01, 0.01, 0.01, 0.01, 0.01});
  constexpr int kSteps = 5000;
  std::vector<double> step_us;
  step_us.reserve(kSteps);
  int incomplete = 0;
  const auto t0 = Clock::now();
  for (int i = 0; i < kSteps; ++i) {
    const auto s0 = Clock::now();
    if (!master.step()) ++incomplete;
    step_us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - s0).count());
  }
  const double s = std::chrono::duration<double>(Clock::now() - t0).count();
  const auto p = percentiles(step_us);
  const auto c = master.counters();
  std::printf("master  %-22s %d lock-step cycles (19 frames each) in %.3f s: %.0f cycles/s; "
              "cycle p50 %.1f us, p99 %.1f us, max %.1f us; incomplete %d, late %llu\n",
              spec.c_str(), kSteps, s, kSteps / s, p.p50_us, p.p99_us, p.max_us, incomplete,
              static_cast<unsigned long long>(c.late_frames));
}

}  // namespace

int main(int argc, char** argv) {
  const std::string bus = argc > 1 ? argv[1] : "local";
  std::unique_ptr<LocalHub> hub;
  std::filesystem::path dir;
  std::string spec = bus;
  if (bus == "local") {
    char pattern[] = "/tmp/rtm-can-bench-XXXXXX";
    if (!mkdtemp(pattern)) return 1;
    dir = pattern;
    hub = std::make_unique<LocalHub>((dir / "bus").string());
    spec = "local:" + (dir / "bus").string();
  }
  try {
    burst(spec);
    ping_pong(spec);
    cycle_write(spec, false);
    cycle_write(spec, true);
    lock_step(spec);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "can_transport_bench: %s\n", e.what());
    return 1;
  }
  if (hub) {
    const auto c = hub->counters();
    std::printf("hub     forwarded %llu frames, %llu deliveries, %llu dropped\n",
                static_cast<unsigned long long>(c.frames_forwarded),
                static_cast<unsigned long long>(c.deliveries),
                static_cast<unsigned long long>(c.deliveries_dropped));
    hub.reset();
    std::filesystem::remove_all(dir);
  }
  return 0;
}
