// SPDX-License-Identifier: Apache-2.0
// pa10-sim's cost per simulated millisecond, headless: the MuJoCo plant alone (arm held in the
// air, and held pressing on the table so contact is solved every step), and a whole lock-step
// SYNC cycle (7 RPDOs + SYNC in, 2 physics steps, 7 drive TPDOs + 4 sensor PDOs out) without a
// transport. real_time_factor = simulated time / wall time (target >= 20).
#include <benchmark/benchmark.h>

#include <mujoco/mujoco.h>

#include "arm/can/protocol.h"
#include "sim/simulator.h"

namespace pc = rtm::can;
using rtm::sim::JointCommand;
using rtm::sim::Pa10Plant;
using rtm::sim::Pa10Simulator;

namespace {

class NullSink final : public rtm::sim::FrameSink {
 public:
  void send(const can_frame&) override { ++frames; }
  std::uint64_t frames = 0;
};

void report(benchmark::State& state, double sim_s_per_iteration) {
  state.counters["steps_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()) * sim_s_per_iteration / 0.001,
                         benchmark::Counter::kIsRate);
  state.counters["real_time_factor"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * sim_s_per_iteration, benchmark::Counter::kIsRate);
}

void BM_PlantStepArmHeldInTheAir(benchmark::State& state) {
  Pa10Plant plant(RTM_PA10_SCENE);
  for (auto _ : state) plant.step();
  report(state, plant.timestep_s());
}
BENCHMARK(BM_PlantStepArmHeldInTheAir);

void BM_PlantStepToolPressingOnTheTable(benchmark::State& state) {
  Pa10Plant plant(RTM_PA10_SCENE);
  // E1 folds the forearm down until the tip touches the table, a little further, then holds.
  plant.set_command(3, {JointCommand::Mode::velocity, 0.05});
  int contact_steps = 0;
  for (int i = 0; i < 20000 && contact_steps < 100; ++i) {
    plant.step();
    if (plant.data()->ncon > 0) ++contact_steps;
  }
  plant.set_command(3, {});
  if (plant.data()->ncon == 0) state.SkipWithError("the tool never touched the table");
  for (auto _ : state) plant.step();
  state.counters["contacts"] = plant.data()->ncon;
  report(state, plant.timestep_s());
}
BENCHMARK(BM_PlantStepToolPressingOnTheTable);

void BM_LockStepSyncCycle(benchmark::State& state) {
  rtm::sim::SimulatorConfig config;
  config.scene_path = RTM_PA10_SCENE;
  Pa10Simulator sim(config);
  sim.set_mode(Pa10Simulator::Mode::lock_step);
  NullSink sink;
  sim.power_on(sink);
  for (int j = 0; j < 7; ++j)
    sim.on_frame(*pc::encode_sdo_request({pc::drive_node(j), pc::SdoRequestKind::download,
                                          pc::object::kModesOfOperation, 0, 9, 1}),
                 sink);
  sim.on_frame(*pc::encode_nmt(pc::NmtCommand::start, 0), sink);
  std::array<can_frame, 7> rpdo{};
  std::uint8_t counter = 0;
  auto cycle = [&](std::uint16_t controlword, double velocity_rad_s) {
    for (int j = 0; j < 7; ++j) {
      rpdo[static_cast<std::size_t>(j)] =
          *pc::encode_drive_command({pc::drive_node(j), controlword, velocity_rad_s});
      sim.on_frame(rpdo[static_cast<std::size_t>(j)], sink);
    }
    counter = pc::next_sync_counter(counter);
    sim.on_frame(*pc::encode_sync(counter), sink);
  };
  for (std::uint16_t cw : {pc::controlword::kShutdown, pc::controlword::kSwitchOn,
                           pc::controlword::kEnableOperation})
    cycle(cw, 0);
  double velocity_rad_s = 0.05;
  int n = 0;
  for (auto _ : state) {
    // Back and forth so the arm stays within its limits however long the benchmark runs.
    if (++n % 500 == 0) velocity_rad_s = -velocity_rad_s;
    cycle(pc::controlword::kEnableOperation, velocity_rad_s);
  }
  state.counters["frames_out_per_cycle"] =
      static_cast<double>(sink.frames) / static_cast<double>(n + 3);
  report(state, 0.002);
}
BENCHMARK(BM_LockStepSyncCycle);

}  // namespace

BENCHMARK_MAIN();
