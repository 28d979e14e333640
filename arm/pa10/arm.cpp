// SPDX-License-Identifier: Apache-2.0
#include "arm/pa10/arm.h"

#include "arm/can/master.h"

#include <cstdio>

namespace rtm::pa10 {
using rtm::can::FaultKind;

namespace {

// The joint positions of a state the master published, s1..w2.
JointVector positions(const rtm::can::JointState& state) {
  JointVector q_rad;
  for (int j = 0; j < kJointCount; ++j) q_rad[j] = state.position_rad[j];
  return q_rad;
}

}  // namespace

Pa10Arm::Pa10Arm(rtm::can::Pa10Master& master, ArmOptions options) : Pa10Arm(std::string(), master, options) {}

Pa10Arm::Pa10Arm(const std::string& urdf_path, rtm::can::Pa10Master& master, ArmOptions options)
    : kinematics_(Kinematics::pa10(urdf_path)),
      ik_(kinematics_, options.ik),
      master_(master),
      options_(options) {
  if (!(options_.period_s > 0))
    throw std::invalid_argument("Pa10Arm: period_s must be positive (the master's SYNC period)");
}

FaultKind Pa10Arm::set_state(FaultKind state, const char* detail) {
  if (fault_.load(std::memory_order_relaxed) == state) return state;
  {
    std::lock_guard lock(reason_mutex_);
    if (state == FaultKind::none)
      fault_reason_[0] = '\0';
    else
      std::snprintf(fault_reason_.data(), fault_reason_.size(), "%s: %s", to_string(state).data(), detail);
  }
  fault_.store(state, std::memory_order_release);
  return state;
}

FaultKind Pa10Arm::latch(FaultKind fault, const char* detail) {
  latched_ = true;
  set_state(fault, detail);
  command_zero();
  return fault;
}

void Pa10Arm::command_zero() { master_.set_target_velocities({}); }

FaultKind Pa10Arm::check_faults() {
  if (latched_) return fault();
  // enabled() is the cheap check; fault() copies a reason string, so it is read only when the
  // master is not enabled.
  if (master_.enabled()) return set_state(FaultKind::none, "");
  // Pa10Master::fault_reset() is taken up by the master's next cycle: until a state from that
  // cycle is published, fault() still shows the fault being reset.
  if (reset_pending_.load(std::memory_order_acquire)) {
    if (master_.joint_state().cycle <= cycle_at_reset_.load(std::memory_order_acquire))
      return set_state(FaultKind::not_enabled, "fault reset requested, waiting for the master");
    reset_pending_.store(false, std::memory_order_release);
  }
  const rtm::can::MasterFault master_fault = master_.fault();
  // The master's kind as it latched it: one vocabulary, no mapping.
  if (master_fault.active()) return latch(master_fault.kind, master_fault.reason.c_str());
  return set_state(FaultKind::not_enabled, "the master has not enabled every drive");
}

FaultKind Pa10Arm::order_velocity(const std::array<float, 6>& twist_base) {
  if (const FaultKind state = check_faults(); state != FaultKind::none) {
    command_zero();
    return state;
  }
  const rtm::can::JointState state = master_.joint_state();
  if (state.cycle == 0) {  // enabled but no feedback yet: q unknown, do not move
    command_zero();
    return set_state(FaultKind::not_enabled, "no feedback from the drives yet");
  }
  const JointVector q_rad = positions(state);
  Twist twist;
  for (int i = 0; i < 6; ++i) twist[i] = twist_base[i];

  last_ik_ = ik_.solve(twist, q_rad, options_.period_s);
  if (last_ik_.status != IkStatus::ok) return latch(FaultKind::ik_failed, last_ik_.error);
  std::array<double, rtm::can::kDriveCount> target_rad_s{};
  for (int j = 0; j < kJointCount; ++j) target_rad_s[j] = last_ik_.qdot_rad_s[j];
  master_.set_target_velocities(target_rad_s);
  return FaultKind::none;
}

void Pa10Arm::stop() { command_zero(); }

FaultKind Pa10Arm::quick_stop() {
  if (const FaultKind state = check_faults(); state != FaultKind::none) {
    command_zero();
    return state;
  }
  master_.quick_stop();
  return FaultKind::none;
}

JointVector Pa10Arm::joint_positions() const { return positions(master_.joint_state()); }

JointVector Pa10Arm::joint_velocities() const {
  const rtm::can::JointState state = master_.joint_state();
  JointVector qdot_rad_s;
  for (int j = 0; j < kJointCount; ++j) qdot_rad_s[j] = state.velocity_rad_s[j];
  return qdot_rad_s;
}

Eigen::Isometry3d Pa10Arm::tool_pose() { return kinematics_.tool_pose(joint_positions()); }

bool Pa10Arm::measured_tool_pose(Eigen::Isometry3d& pose) {
  const rtm::can::JointState state = master_.joint_state();
  if (state.cycle == 0) return false;
  pose = kinematics_.tool_pose(positions(state));
  return true;
}

std::string Pa10Arm::fault_reason() const {
  std::lock_guard lock(reason_mutex_);
  return std::string(fault_reason_.data());
}

void Pa10Arm::reset() {
  command_zero();
  cycle_at_reset_.store(master_.joint_state().cycle, std::memory_order_release);
  reset_pending_.store(true, std::memory_order_release);
  master_.fault_reset();
  latched_ = false;
  last_ik_ = VelocityIkResult{};
  set_state(FaultKind::not_enabled, "fault reset requested, waiting for the drives");
}

}  // namespace rtm::pa10
