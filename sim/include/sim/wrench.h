// SPDX-License-Identifier: Apache-2.0
// A force/torque pair, the value the simulator's two force sensors measure.
#pragma once

#include <array>

namespace rtm::sim {

// Force and torque in one frame (the sensor's), torque taken about that frame's origin.
struct Wrench {
  std::array<double, 3> force_N{};    // N
  std::array<double, 3> torque_Nm{};  // N·m

  friend bool operator==(const Wrench&, const Wrench&) = default;
};

}  // namespace rtm::sim
