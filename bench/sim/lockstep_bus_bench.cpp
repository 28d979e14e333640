// SPDX-License-Identifier: Apache-2.0
// Lock-step speed across processes: Pa10Master.step() against a pa10-sim --lockstep child over
// the local bus (hub inside pa10-sim). Each cycle: 7 RPDOs + SYNC out, 2 physics steps, 7 drive
// TPDOs + 4 sensor PDOs back. Prints cycles/s, the real-time factor (2 ms of sim time per
// cycle) and the step() latency percentiles.
// usage: sim_lockstep_bus_bench <pa10-sim> [cycles]
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "arm/can/master.h"

extern char** environ;

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s <pa10-sim> [cycles]\n", argv[0]);
    return 2;
  }
  const int cycles = argc > 2 ? std::atoi(argv[2]) : 5000;
  const std::string path = "/tmp/rtm-sim-bench-" + std::to_string(::getpid()) + ".bus";
  const std::string spec = "local:" + path;
  std::vector<std::string> args{argv[1], "--bus", spec, "--lockstep", "--quiet"};
  std::vector<char*> child_argv;
  for (auto& a : args) child_argv.push_back(a.data());
  child_argv.push_back(nullptr);
  pid_t sim = -1;
  if (posix_spawn(&sim, argv[1], nullptr, nullptr, child_argv.data(), environ) != 0) {
    std::perror("posix_spawn pa10-sim");
    return 1;
  }
  int rc = 0;
  try {
    for (int i = 0; i < 200 && !std::filesystem::exists(path); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    rtm::can::MasterConfig config;
    config.step_timeout_ns = 2'000'000'000;
    rtm::can::Pa10Master master(spec, "", config);
    master.start();
    std::vector<double> step_us;
    step_us.reserve(static_cast<std::size_t>(cycles));
    std::array<double, rtm::can::kDriveCount> velocity{};
    int incomplete = 0;
    const auto begin = std::chrono::steady_clock::now();
    for (int i = 0; i < cycles; ++i) {
      velocity[0] = (i / 500) % 2 ? -0.05 : 0.05;  // keep the arm moving, within its limits
      master.set_target_velocities(velocity);
      const auto t0 = std::chrono::steady_clock::now();
      if (!master.step()) ++incomplete;
      step_us.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count());
    }
    const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
    std::sort(step_us.begin(), step_us.end());
    auto pct = [&](double p) { return step_us[static_cast<std::size_t>(p * (step_us.size() - 1))]; };
    std::printf("lock-step over local bus: %d cycles in %.3f s = %.0f cycles/s, real-time factor %.1f\n",
                cycles, wall_s, cycles / wall_s, cycles * 0.002 / wall_s);
    std::printf("step() latency us: p50 %.1f  p90 %.1f  p99 %.1f  max %.1f; incomplete cycles %d\n",
                pct(0.5), pct(0.9), pct(0.99), step_us.back(), incomplete);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "sim_lockstep_bus_bench: %s\n", error.what());
    rc = 1;
  }
  kill(sim, SIGTERM);
  int status = 0;
  waitpid(sim, &status, 0);
  return rc;
}
