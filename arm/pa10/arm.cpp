#include "arm/pa10/arm.h"

#include "arm/can/master.h"

#include <cstdio>

namespace rtm::pa10 {
namespace {

ArmFault arm_fault_of(const rtm::can::MasterFault& fault) {
  using rtm::can::FaultKind;
  if (fault.kind == FaultKind::emergency && fault.code == rtm::can::emcy::kRpdoTimeout)
    return ArmFault::command_loss;
  switch (fault.kind) {
    case FaultKind::none: return ArmFault::none;
    case FaultKind::heartbeat_lost: return ArmFault::heartbeat_lost;
    case FaultKind::bus_error:
    case FaultKind::cycle_owner_lost: return ArmFault::bus_error;
    case FaultKind::drive_fault:
    case FaultKind::drive_disabled:
    case FaultKind::emergency:
    case FaultKind::missing_feedback:
    case FaultKind::node_not_operational: return ArmFault::drive_fault;
  }
  return ArmFault::drive_fault;
}

}  // namespace

const char* to_string(ArmFault fault) {
  switch (fault) {
    case ArmFault::none: return "none";
    case ArmFault::not_enabled: return "not_enabled";
    case ArmFault::drive_fault: return "drive_fault";
    case ArmFault::command_loss: return "command_loss";
    case ArmFault::heartbeat_lost: return "heartbeat_lost";
    case ArmFault::bus_error: return "bus_error";
    case ArmFault::ik_failed: return "ik_failed";
  }
  return "unknown";
}

Pa10Arm::Pa10Arm(const std::string& urdf_path, rtm::can::Pa10Master& master, ArmOptions options)
    : kinematics_(Kinematics::from_urdf_file(urdf_path)),
      ik_(kinematics_, options.ik),
      master_(master),
      options_(options) {
  if (!(options_.period_s > 0))
    throw std::invalid_argument("Pa10Arm: period_s must be positive (the master's SYNC period)");
}

void Pa10Arm::set_state(ArmFault state, const char* detail) {
  if (fault_.load(std::memory_order_relaxed) == state) return;
  {
    std::lock_guard lock(reason_mutex_);
    if (state == ArmFault::none)
      fault_reason_[0] = '\0';
    else
      std::snprintf(fault_reason_.data(), fault_reason_.size(), "%s: %s", to_string(state), detail);
  }
  fault_.store(state, std::memory_order_release);
}

void Pa10Arm::latch(ArmFault fault, const char* detail) {
  latched_ = true;
  set_state(fault, detail);
  command_zero();
}

void Pa10Arm::command_zero() { master_.set_target_velocities({}); }

ArmFault Pa10Arm::check_faults() {
  if (latched_) return fault();
  // enabled() is the cheap check; fault() copies a reason string, so it is read only when the
  // master is not enabled.
  if (master_.enabled()) {
    set_state(ArmFault::none, "");
    return ArmFault::none;
  }
  // Pa10Master::fault_reset() is taken up by the master's next cycle: until a state from that
  // cycle is published, fault() still shows the fault being reset.
  if (reset_pending_.load(std::memory_order_acquire)) {
    if (master_.joint_state().cycle <= cycle_at_reset_.load(std::memory_order_acquire)) {
      set_state(ArmFault::not_enabled, "fault reset requested, waiting for the master");
      return ArmFault::not_enabled;
    }
    reset_pending_.store(false, std::memory_order_release);
  }
  const rtm::can::MasterFault master_fault = master_.fault();
  if (master_fault.active()) {
    latch(arm_fault_of(master_fault), master_fault.reason.c_str());
    return fault();
  }
  set_state(ArmFault::not_enabled, "the master has not enabled every drive");
  return ArmFault::not_enabled;
}

bool Pa10Arm::order_velocity(const std::array<float, 6>& twist_base) {
  if (check_faults() != ArmFault::none) {
    command_zero();
    return false;
  }
  const rtm::can::JointState state = master_.joint_state();
  if (state.cycle == 0) {  // enabled but no feedback yet: q unknown, do not move
    command_zero();
    return false;
  }
  JointVector q_rad;
  for (int j = 0; j < kJointCount; ++j) q_rad[j] = state.position_rad[j];
  Twist twist;
  for (int i = 0; i < 6; ++i) twist[i] = twist_base[i];

  last_ik_ = ik_.solve(twist, q_rad, options_.period_s);
  if (last_ik_.status != IkStatus::ok) {
    latch(ArmFault::ik_failed, last_ik_.error);
    return false;
  }
  std::array<double, rtm::can::kDriveCount> target_rad_s{};
  for (int j = 0; j < kJointCount; ++j) target_rad_s[j] = last_ik_.qdot_rad_s[j];
  master_.set_target_velocities(target_rad_s);
  return true;
}

void Pa10Arm::stop() { command_zero(); }

bool Pa10Arm::quick_stop() {
  if (check_faults() != ArmFault::none) {
    command_zero();
    return false;
  }
  master_.quick_stop();
  return true;
}

JointVector Pa10Arm::joint_positions() const {
  const rtm::can::JointState state = master_.joint_state();
  JointVector q_rad;
  for (int j = 0; j < kJointCount; ++j) q_rad[j] = state.position_rad[j];
  return q_rad;
}

JointVector Pa10Arm::joint_velocities() const {
  const rtm::can::JointState state = master_.joint_state();
  JointVector qdot_rad_s;
  for (int j = 0; j < kJointCount; ++j) qdot_rad_s[j] = state.velocity_rad_s[j];
  return qdot_rad_s;
}

Eigen::Isometry3d Pa10Arm::tool_pose() { return kinematics_.tool_pose(joint_positions()); }

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
  set_state(ArmFault::not_enabled, "fault reset requested, waiting for the drives");
}

}  // namespace rtm::pa10
