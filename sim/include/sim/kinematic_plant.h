// SPDX-License-Identifier: Apache-2.0
// A plant with no dynamics, for tests of what talks to the CAN nodes (the master): a joint in
// velocity mode moves at exactly its target velocity (position integrates it over each step),
// a joint in hold stands still; the wrist sensor reads whatever set_wrist_wrench() last set,
// the joystick sensor the operator's wrench (a massless handle). No MuJoCo: lock-step results
// are exact.
#pragma once

#include <array>

#include "sim/plant.h"

namespace rtm::sim {

class KinematicPlant final : public Plant {
 public:
  explicit KinematicPlant(double timestep_s = 0.001) : timestep_s_(timestep_s) {}

  void set_command(int joint, const JointCommand& command) override {
    commands_[index(joint)] = command;
  }
  void set_operator_wrench(const Wrench& wrench) override { joystick_ = wrench; }
  // The contact wrench on the tool, as the wrist sensor measures it.
  void set_wrist_wrench(const Wrench& wrench) { wrist_ = wrench; }
  void set_joint_position(int joint, double position_rad) { joints_[index(joint)].position_rad = position_rad; }
  // A joint that moves at this velocity whatever it is commanded (a released brake under load,
  // a drive running on someone else's command): what the master's following-error check is for.
  // 0 ends it.
  void set_runaway_velocity(int joint, double velocity_rad_s) { runaway_[index(joint)] = velocity_rad_s; }

  void step() override {
    for (std::size_t j = 0; j < joints_.size(); ++j) {
      const bool moving = commands_[j].mode == JointCommand::Mode::velocity;
      joints_[j].velocity_rad_s = (moving ? commands_[j].target_velocity_rad_s : 0.0) + runaway_[j];
      joints_[j].position_rad += joints_[j].velocity_rad_s * timestep_s_;
    }
  }

  double timestep_s() const override { return timestep_s_; }
  JointState joint_state(int joint) const override { return joints_[index(joint)]; }
  Wrench wrist_wrench() const override { return wrist_; }
  Wrench joystick_wrench() const override { return joystick_; }

 private:
  static std::size_t index(int joint) { return static_cast<std::size_t>(joint); }

  double timestep_s_;
  std::array<JointCommand, kJointCount> commands_{};
  std::array<double, kJointCount> runaway_{};
  std::array<JointState, kJointCount> joints_{};
  Wrench wrist_{};
  Wrench joystick_{};
};

}  // namespace rtm::sim
