// SPDX-License-Identifier: Apache-2.0
// Pa10Simulator: the PA10 scene in MuJoCo behind its nine CAN nodes: a Pa10Rig on a
// Pa10Plant, loaded from the scene and set to its initial keyframe. Everything on the CAN
// side (modes, frames, time, taring, the operator) is the rig's (sim/pa10_rig.h).
#pragma once

#include <memory>
#include <string>

#include "sim/operator_profile.h"
#include "sim/pa10_plant.h"
#include "sim/pa10_rig.h"

namespace rtm::sim {

struct SimulatorConfig {
  std::string scene_path;                        // the MJCF (sim/models/pa10_scene.xml)
  std::string initial_keyframe = "ready";
  std::int64_t sync_period_ns = 2'000'000;       // lock-step: physics advanced per SYNC
  int tare_samples = 20;                         // steps held still to tare the sensors
  ServoGains gains{};
  Surface surface = default_surface();           // the table top (scenes with a "surface" joint)
  OperatorProfile operator_profile{};            // the joystick's wrench over sim time
};

class Pa10Simulator : public Pa10Rig {
 public:
  explicit Pa10Simulator(SimulatorConfig config);  // throws SceneError

  Pa10Plant& plant() { return *plant_; }

 private:
  Pa10Simulator(std::unique_ptr<Pa10Plant> plant, const SimulatorConfig& config);

  // The rig (the base) holds a reference to it; constructed before the base, destroyed after
  // the base stopped using it (the rig's destructor does not touch the plant).
  std::unique_ptr<Pa10Plant> plant_;
};

}  // namespace rtm::sim
