// SPDX-License-Identifier: Apache-2.0
#include "sim/simulator.h"

#include <cmath>
#include <utility>

namespace rtm::sim {

namespace {

// The scene, at its initial keyframe; SceneError when its timestep does not divide the SYNC
// period (checked here so the error names the scene).
std::unique_ptr<Pa10Plant> load_plant(const SimulatorConfig& config) {
  auto plant = std::make_unique<Pa10Plant>(config.scene_path, config.gains, config.surface);
  plant->reset_to_keyframe(config.initial_keyframe);
  const std::int64_t timestep_ns = std::llround(plant->timestep_s() * 1e9);
  if (timestep_ns <= 0 || config.sync_period_ns % timestep_ns != 0)
    throw SceneError(config.scene_path + ": the timestep (" + std::to_string(timestep_ns) +
                     " ns) must divide the SYNC period (" +
                     std::to_string(config.sync_period_ns) + " ns)");
  return plant;
}

RigConfig rig_config(const SimulatorConfig& config) {
  RigConfig rig;
  rig.sync_period_ns = config.sync_period_ns;
  rig.tare_samples = config.tare_samples;
  rig.operator_profile = config.operator_profile;
  return rig;
}

}  // namespace

Pa10Simulator::Pa10Simulator(SimulatorConfig config)
    : Pa10Simulator(load_plant(config), config) {}

Pa10Simulator::Pa10Simulator(std::unique_ptr<Pa10Plant> plant, const SimulatorConfig& config)
    : Pa10Rig(*plant, rig_config(config)), plant_(std::move(plant)) {}

}  // namespace rtm::sim
