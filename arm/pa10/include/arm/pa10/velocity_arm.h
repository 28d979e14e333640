// SPDX-License-Identifier: Apache-2.0
// The arm as a component sees it: a seam of five calls (command a twist, brake, stop, say its
// fault, reset), the tool pose it measures, and a read-only diagnostics view beside it, which
// the arm hands its base. ArmHardware is the real one (Pa10Master + Pa10Arm, on pa10-sim or the
// PA10 alike); tests put the one recording fake of tests/support (rtm_test/recording_arm.h)
// behind the same seam.
#pragma once

#include "arm/can/bus_options.h"
#include "arm/can/fault.h"
#include "arm/can/master.h"
#include "arm/pa10/arm.h"

#include <array>
#include <cstdint>
#include <memory>
#include <string>

namespace CLI {
class App;
}

namespace rtm::pa10 {

using rtm::can::FaultKind;
using rtm::can::Recovery;

// The fault the arm holds now, as every layer of the arm library says it (arm/can/fault.h);
// rtm::can::recovery(fault) says what the component may do about it.
using ArmFault = rtm::can::Fault;

// What the arm's bus says, for reports and the sample-to-drive latency: reading it changes
// nothing. Each call is cheap and allocates nothing.
class ArmDiagnostics {
 public:
  virtual ~ArmDiagnostics() = default;
  // The SYNC cycle (counting from 1) and the CANopen SYNC counter (1..240) the arm's latest
  // feedback answers; 0 when unknown.
  struct BusPosition {
    std::uint64_t cycle = 0;
    std::uint8_t sync_counter = 0;
  };
  virtual BusPosition bus_position() const { return {}; }
  // The sequence number of the target the last ready order_velocity() handed to the bus master,
  // and the last target that has left for the bus (sequence, CLOCK_REALTIME ns of the RPDO
  // write). 0 / {0, 0} when the arm cannot tell.
  struct SentCommand {
    std::uint64_t sequence = 0;
    std::int64_t sent_realtime_ns = 0;
  };
  virtual std::uint64_t command_sequence() const { return 0; }
  virtual SentCommand last_sent() const { return {}; }
  // What the bus master saw of frames it did not send and of the drives' following errors
  // (rtm::can::MasterCounters); zeros when the arm has no bus.
  struct BusHealth {
    std::uint64_t foreign_frames = 0;
    std::uint64_t unsolicited_frames = 0;
    double peak_velocity_error_rad_s = 0;
    double peak_position_error_rad = 0;
    std::uint64_t target_expiries = 0;  // targets the master dropped as not renewed in time
  };
  virtual BusHealth bus_health() const { return {}; }
};

// The arm the actuator commands each cycle: five calls and the measured pose, made by one thread
// at a time (the actuator's cycle and its on_start/on_stop), and the diagnostics view, read from
// any thread.
class VelocityArm {
 public:
  virtual ~VelocityArm() = default;
  VelocityArm(const VelocityArm&) = delete;
  VelocityArm& operator=(const VelocityArm&) = delete;

  // Twist of the tool in the BASE frame (vx vy vz m/s, wx wy wz rad/s) for the next period.
  // none: handed to the drives; not_enabled: drives not (yet) enabled, zero was commanded,
  // clears by itself; anything else is latched (zero until reset(), fault() says more).
  // Allocates nothing.
  virtual FaultKind order_velocity(const std::array<float, 6>& twist_base) = 0;
  // Brakes: the drives stop where they are (CiA 402 quick stop) from the next cycle on, and
  // stay braked until the next order_velocity(). Allocates nothing. none when commanded.
  virtual FaultKind quick_stop() = 0;
  // Commands zero velocity; returns once that command has left for the bus (when the bus runs
  // on its own clock) or is set for the next cycle (lock-step, or the bus cycle run by the
  // caller's tick). For the component's off().
  virtual void stop() = 0;
  // The fault latched now, re-read from the bus master (while the component is off nobody
  // orders velocities, so a fault latched meanwhile is found here). May allocate: asked on
  // the fault path and at on() only.
  virtual ArmFault fault() const = 0;
  virtual void reset() = 0;
  // The tool's pose in the BASE frame from the drives' latest measured joint positions: x y z
  // (m), then the orientation as a rotation vector rx ry rz (axis * angle, rad; pose_vector(),
  // arm/pa10/kinematics.h). false, pose untouched, when the arm cannot tell (no feedback from
  // the drives yet; an arm without joint feedback). Same thread as order_velocity();
  // allocates nothing.
  virtual bool measured_tool_pose(std::array<double, 6>& /*pose*/) { return false; }
  // The read-only view of the arm's bus.
  const ArmDiagnostics& diagnostics() const { return diagnostics_; }

 protected:
  // diagnostics: lives as long as the arm (a member of the derived class may be given here).
  explicit VelocityArm(const ArmDiagnostics& diagnostics) : diagnostics_(diagnostics) {}

 private:
  const ArmDiagnostics& diagnostics_;
};

// The PA10 behind its CANopen master: owns the master (NMT master, SYNC producer) and the arm
// library. With run_master_thread the master runs its own 2 ms SYNC thread from construction
// to destruction, whatever the component does (zero velocity while off, so the drives never
// time out); without it a lock-step caller calls master().step() after each cycle.
class ArmHardware final : public VelocityArm {
 public:
  struct Options : rtm::can::BusOptions {
    std::string urdf;                             // arm model URDF; "" = the arm library's built-in PA10
    std::int64_t period_ns = 2'000'000;           // SYNC period
    bool run_master_thread = true;
    int rt_priority = 0;  // of the master's thread; 0 = SCHED_OTHER
    int cpu = -1;
    std::int64_t master_first_deadline_ns = 0;  // rtm::can::MasterConfig::first_deadline_ns
    std::int64_t step_timeout_ns = 2'000'000'000;  // lock-step wait per SYNC
    // The master's following-error windows (rtm::can::MasterConfig; 0 turns one off).
    double following_velocity_window_rad_s = rtm::can::MasterConfig{}.following_velocity_window_rad_s;
    double following_position_window_rad = rtm::can::MasterConfig{}.following_position_window_rad;
    int following_position_periods = rtm::can::MasterConfig{}.following_position_periods;
    int following_error_periods = rtm::can::MasterConfig{}.following_error_periods;
    int missed_feedback_limit = rtm::can::MasterConfig{}.missed_feedback_limit;

    // Registers --bus, --sensor-bus (BusOptions), --urdf and the following-error windows on
    // app, bound to these fields, each with its range.
    void add_options(CLI::App& app);
  };

  // Opens the buses and starts the master (blocks until every drive is enabled). Throws
  // std::runtime_error / rtm::can::BusError / rtm::pa10::ModelError naming what failed.
  explicit ArmHardware(const Options& options);
  ~ArmHardware() override;  // zero velocity, master thread stopped, drives shut down cleanly

  FaultKind order_velocity(const std::array<float, 6>& twist_base) override { return arm_->order_velocity(twist_base); }
  FaultKind quick_stop() override { return arm_->quick_stop(); }
  void stop() override;
  ArmFault fault() const override;
  void reset() override { arm_->reset(); }
  // Pa10Arm::measured_tool_pose (forward kinematics of the joint positions the drives last
  // reported), as pose_vector(): false until the drives have answered a SYNC.
  bool measured_tool_pose(std::array<double, 6>& pose) override;

  rtm::can::Pa10Master& master() { return *master_; }
  Pa10Arm& arm() { return *arm_; }
  const Options& options() const { return options_; }

 private:
  // The view of the master's state and counters.
  class Diagnostics final : public ArmDiagnostics {
   public:
    explicit Diagnostics(const ArmHardware& arm) : arm_(arm) {}
    BusPosition bus_position() const override;
    std::uint64_t command_sequence() const override;
    SentCommand last_sent() const override;
    BusHealth bus_health() const override;

   private:
    const ArmHardware& arm_;
  };

  Diagnostics diagnostics_{*this};
  Options options_;
  std::unique_ptr<rtm::can::Pa10Master> master_;
  std::unique_ptr<Pa10Arm> arm_;
};

}  // namespace rtm::pa10
