// SPDX-License-Identifier: Apache-2.0
// Pa10Arm: the arm as the force servo's actuator sees it (the paper's `palib`).
// order_velocity() takes a Cartesian twist in the base frame, runs the velocity IK and hands
// the joint rates to the CANopen master; joint state and the tool pose come back from the
// drives' TPDOs. The same code drives the real PA10 and pa10-sim: only the bus differs.
//
// Faults are the master's rtm::can::FaultKind (arm/can/fault.h), reported as the master latched
// them, plus ik_failed found here. A fault (drive fault, EMCY, command loss, heartbeat loss, bus
// error, IK failure, ...) latches: from then on the arm commands zero velocity and
// fault_reason() says why, until reset(). While the master is not (yet, or again after a reset)
// enabling every drive, the arm reports not_enabled and commands zero; that state is not
// latched and clears by itself once the master is enabled.
//
// Works with a master that runs its own 2 ms SYNC thread (real time) and with a master
// stepped in lock-step by a test or the simulator: the arm never sends SYNC itself, it only
// sets the targets the master sends with the next cycle.
#pragma once

#include "arm/can/fault.h"
#include "arm/pa10/kinematics.h"

#include <array>
#include <atomic>
#include <cstdint>
#include <mutex>
#include <string>

namespace rtm::can {
class Pa10Master;
}

namespace rtm::pa10 {

struct ArmOptions {
  // How long a commanded rate is applied: the master's SYNC period.
  double period_s = 0.002;
  VelocityIkOptions ik{};
};

class Pa10Arm {
 public:
  // The PA10 with the library's built-in model (Kinematics::pa10()). `master` must outlive the
  // arm; the arm does not start, stop or step it (call master.start() first, then either
  // master.run_periodic() or master.step() after each order_velocity()).
  explicit Pa10Arm(rtm::can::Pa10Master& master, ArmOptions options = {});
  // The same with the model from `urdf_path` instead, when not empty (throws ModelError naming
  // the file).
  Pa10Arm(const std::string& urdf_path, rtm::can::Pa10Master& master, ArmOptions options = {});
  Pa10Arm(const Pa10Arm&) = delete;
  Pa10Arm& operator=(const Pa10Arm&) = delete;

  // Commands a tool0 twist (vx, vy, vz m/s, wx, wy, wz rad/s; base frame) for the next
  // period. Returns none when the joint rates were handed to the master; otherwise the arm's
  // state (not_enabled, or the latched fault, including one found by this call) and zero joint
  // rates are commanded. Allocates nothing; call from one thread.
  can::FaultKind order_velocity(const std::array<float, 6>& twist_base);
  // Commands zero joint rates (keeps the drives enabled).
  void stop();
  // Brakes the drives (CiA 402 quick stop, see Pa10Master::quick_stop()) and keeps them braked
  // until the next order_velocity(). Returns none when the brake was commanded, otherwise the
  // arm's state as order_velocity() (zero is commanded). Allocates nothing; same thread as
  // order_velocity().
  can::FaultKind quick_stop();

  // Latest measured joint state (from the drives' TPDOs), s1..w2.
  JointVector joint_positions() const;   // rad
  JointVector joint_velocities() const;  // rad/s
  // Tool pose in the base frame from the measured joint positions. Same thread as
  // order_velocity() (uses the kinematics' scratch).
  Eigen::Isometry3d tool_pose();
  // The same from one reading of the joint state, false (pose untouched) while the drives have
  // not answered a SYNC yet (joint_state().cycle == 0: the positions are not known). Allocates
  // nothing; same thread as order_velocity().
  bool measured_tool_pose(Eigen::Isometry3d& pose);

  // Re-reads the master's state; latches a fault if it finds one and returns the arm's state
  // (none when ready to move). order_velocity() does this every call.
  can::FaultKind check_faults();
  // The latched fault, or not_enabled / none as last seen by order_velocity()/check_faults().
  // Thread-safe.
  can::FaultKind fault() const { return fault_.load(std::memory_order_acquire); }
  // True while the arm will not move: a latched fault or not_enabled.
  bool in_fault() const { return fault() != can::FaultKind::none; }
  // Human-readable reason ("" when none), e.g.
  // "command_loss: drive 4 (E1): EMCY 0x8250 RPDO timeout (command loss)". Thread-safe.
  std::string fault_reason() const;

  // Clears the latched fault and asks the master for a fault reset and re-enable of the
  // drives; returns at once. The arm reports not_enabled (zero rates) until the master is
  // enabled again, or latches the master's new fault if the drives do not come back.
  // Call from the thread that calls order_velocity().
  void reset();

  // The last IK result (scale applied, singularity, held joints) for diagnostics.
  const VelocityIkResult& last_ik() const { return last_ik_; }
  Kinematics& kinematics() { return kinematics_; }
  const ArmOptions& options() const { return options_; }

 private:
  can::FaultKind latch(can::FaultKind fault, const char* detail);
  can::FaultKind set_state(can::FaultKind state, const char* detail);
  void command_zero();

  Kinematics kinematics_;
  VelocityIk ik_;
  rtm::can::Pa10Master& master_;
  ArmOptions options_;
  std::atomic<can::FaultKind> fault_{can::FaultKind::none};
  std::atomic<bool> latched_{false};       // fault_ holds a latched fault
  std::atomic<bool> reset_pending_{false};  // reset() sent, master not yet past that cycle
  std::atomic<std::uint64_t> cycle_at_reset_{0};  // master cycle published when reset() ran
  mutable std::mutex reason_mutex_;        // taken only on a state change and by fault_reason()
  std::array<char, 256> fault_reason_{};  // fixed buffer: no allocation on the cycle path
  VelocityIkResult last_ik_{};
};

}  // namespace rtm::pa10
