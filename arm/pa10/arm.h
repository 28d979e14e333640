// Pa10Arm: the arm as the force servo's actuator sees it (the paper's `palib`).
// orderVelocity() takes a Cartesian twist in the base frame, runs the velocity IK and hands
// the joint rates to the CANopen master; joint state and the tool pose come back from the
// drives' TPDOs. The same code drives the real PA10 and pa10-sim: only the bus differs.
//
// Faults (drive fault, heartbeat loss, IK failure, drives not enabled) latch: from then on
// the arm commands zero velocity and faultReason() says why, until reset() succeeds.
//
// Works with a master that runs its own 2 ms SYNC thread (real time) and with a master
// stepped in lock-step by a test or the simulator: the arm never sends SYNC itself, it only
// sets the targets the master sends with the next cycle.
#pragma once

#include "arm/pa10/kinematics.h"

#include <array>
#include <atomic>
#include <cstdint>
#include <string>

namespace rtm::can {
class Pa10Master;
}

namespace rtm::pa10 {

enum class ArmFault : std::uint8_t {
  none,
  drive_fault,     // a drive reported fault (statusword) or an EMCY other than error reset
  heartbeat_lost,  // a node was silent longer than the heartbeat timeout
  not_enabled,     // a drive left "operation enabled" without a fault (e.g. quick stop)
  ik_failed,       // the twist (or the measured q) was not finite
};

// Short fixed name of a fault kind ("drive_fault", ...).
const char* toString(ArmFault fault);

struct ArmOptions {
  // How long a commanded rate is applied: the master's SYNC period.
  double period_s = 0.002;
  VelocityIkOptions ik{};
};

class Pa10Arm {
 public:
  // Loads the model from `urdf_path` (throws ModelError naming the file). `master` must
  // outlive the arm; the arm does not start or stop it.
  Pa10Arm(const std::string& urdf_path, rtm::can::Pa10Master& master, ArmOptions options = {});
  Pa10Arm(const Pa10Arm&) = delete;
  Pa10Arm& operator=(const Pa10Arm&) = delete;

  // Commands a tool0 twist (vx, vy, vz m/s, wx, wy, wz rad/s; base frame) for the next
  // period. Returns false (and commands zero joint rates) when the arm is in fault, including
  // a fault found by this call. Allocates nothing; call from one thread.
  bool orderVelocity(const std::array<float, 6>& twist_base);
  // Commands zero joint rates (keeps the drives enabled).
  void stop();

  // Latest measured joint state (from the drives' TPDOs), s1..w2.
  JointVector jointPositions() const;   // rad
  JointVector jointVelocities() const;  // rad/s
  // Tool pose in the base frame from the measured joint positions.
  Eigen::Isometry3d toolPose();

  // Re-reads the master's state; latches a fault if it finds one. orderVelocity() does this.
  ArmFault checkFaults();
  ArmFault fault() const { return fault_.load(std::memory_order_acquire); }
  bool inFault() const { return fault() != ArmFault::none; }
  // Human-readable reason of the latched fault ("" when none), e.g.
  // "drive_fault: joint e1 (node 4) statusword 0x0008, EMCY 0x8250".
  std::string faultReason() const;

  // Clears the latched fault: fault reset and re-enable of the drives through the master,
  // zero rates. Throws std::runtime_error with the reason when the drives do not come back
  // (the fault then stays latched).
  void reset();

  // The last IK result (scale applied, singularity, held joints) for diagnostics.
  const VelocityIkResult& lastIk() const { return last_ik_; }
  Kinematics& kinematics() { return kinematics_; }
  const ArmOptions& options() const { return options_; }

 private:
  void latch(ArmFault fault, const char* detail_format, ...);
  void commandZero();

  Kinematics kinematics_;
  VelocityIk ik_;
  rtm::can::Pa10Master& master_;
  ArmOptions options_;
  std::atomic<ArmFault> fault_{ArmFault::none};
  std::array<char, 192> fault_reason_{};  // fixed buffer: latching a fault allocates nothing
  VelocityIkResult last_ik_{};
  JointVector q_rad_ = JointVector::Zero();
  JointVector qdot_rad_s_ = JointVector::Zero();
};

}  // namespace rtm::pa10
