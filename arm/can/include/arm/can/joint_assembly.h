// SPDX-License-Identifier: Apache-2.0
// The drives' answers to one SYNC, put together joint by joint: after each SYNC every drive
// sends its TPDO1 (statusword, position, velocity), in any order. The one place that does it,
// for the master's cycle (bus_cycle.h) and the passive listener (joint_listener.h).
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>

#include "arm/can/master_types.h"
#include "arm/can/protocol.h"

namespace rtm::can {

class JointAssembly {
 public:
  // A new SYNC: no drive has answered it yet (the last answers stay readable).
  void restart() {
    answered_.fill(false);
    twice_.fill(false);
  }
  // A drive's answer. True when that drive had answered this SYNC already: a late answer to an
  // older SYNC, or another sender using its id. Which of the two is genuine is unknown, so from
  // then on the window's values of that drive are withheld (not trusted()).
  bool add(const DriveFeedback& feedback) {
    const auto joint = static_cast<std::size_t>(joint_index_of(feedback.drive));
    const bool again = answered_[joint];
    if (again) twice_[joint] = true;
    else feedback_[joint] = feedback;
    answered_[joint] = true;
    return again;
  }

  bool answered(std::size_t joint) const { return answered_[joint]; }
  // Answered once: its values may be used.
  bool trusted(std::size_t joint) const { return answered_[joint] && !twice_[joint]; }
  const std::array<bool, kDriveCount>& answers() const { return answered_; }
  bool complete() const { return std::ranges::all_of(answered_, [](bool a) { return a; }); }
  const DriveFeedback& feedback(std::size_t joint) const { return feedback_[joint]; }

  // Writes the joints that answered once into `state` (the others keep their last values) and
  // whether all did; the SYNC's counter, time and cycle are the caller's.
  void fill(JointState& state) const {
    bool all = true;
    for (std::size_t i = 0; i < kDriveCount; ++i) {
      if (!trusted(i)) {
        all = false;
        continue;
      }
      state.position_rad[i] = feedback_[i].position_rad;
      state.velocity_rad_s[i] = feedback_[i].velocity_rad_s;
      state.statusword[i] = feedback_[i].statusword;
    }
    state.complete = all;
  }

 private:
  std::array<bool, kDriveCount> answered_{};
  std::array<bool, kDriveCount> twice_{};
  std::array<DriveFeedback, kDriveCount> feedback_{};
};

}  // namespace rtm::can
