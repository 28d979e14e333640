// SPDX-License-Identifier: Apache-2.0
// Actuator: the manipulator driven by Cartesian velocity commands (paper Fig. 7).
//
//   InPort 0 "twist" (alias in0)  velocity command (TimedFloat6, BASE frame: vx vy vz m/s, wx wy wz rad/s)
//   OutPort 0 "pose" (alias out0) the tool's pose the drives measure (TimedFloat6, BASE frame:
//                                 x y z m, rx ry rz rad: the orientation as a rotation vector,
//                                 axis * angle), forward kinematics of the joint positions of
//                                 the drives' latest feedback; stamped when the cycle reads it
//                                 (CLOCK_REALTIME), not with the command's stamp
//
// Parameters: limit (live: the next cycle uses it), watchdog_periods (while off). Statistics:
// the ActuatorCounters and ActuatorLatency, by name (latencies in µs).
//
// Each cycle: take the newest command, clamp each component to ±limit[i] (Fig. 7), hand it to
// the arm (order_velocity), then write the measured pose to "pose" (every cycle the arm can
// tell it, braking or without a command too; none before the drives' first feedback). Safety
// beyond the paper:
//   - watchdog: after watchdog_periods cycles without a new command the drives brake (CiA 402
//     quick stop: they stop where they are, not merely ramp down to a zero command); the
//     cycles before repeat the last command (one late datum must not jerk the arm). The
//     watchdog arms with the first command after on(), so members turned on one after another
//     count no event;
//   - a command holding NaN/inf brakes the same way;
//   each counted and logged once per event (when it starts), not per cycle; the next valid
//   command releases the brake and moves the arm again;
//   - off() commands zero velocity before it returns;
//   - a drive's RPDO timeout (EMCY 0x8250: the bus master's commands came late, e.g. a host
//     stall) is a communication fault: the actuator resets the drives at once and moves again
//     on the next new command, counting and logging each such recovery once;
//   - a heartbeat loss of a force sensor node (the wrist F/T sensor's cable, say) stops the
//     drives (the bus master holds zero while the fault is latched) and is retried: a fault
//     reset every 50 cycles (a heartbeat period) until the node is heard again, then the arm
//     moves on the next new command, as after a command loss; counted and logged once per
//     event. Silence beyond sensor_recovery_periods cycles is an error (below);
//   - any other latched arm fault (drive hardware EMCY, a drive's heartbeat loss, bus error, a
//     failed recovery) puts the component in COMPONENT_ERROR with the reason; on() after
//     reset() asks the arm to reset too.
#pragma once

#include "arm/pa10/velocity_arm.h"

#include "rt/activity.h"
#include "rtm/component.h"
#include "rtm/freshness.h"
#include "rt/histogram.h"
#include "rt/live_value.h"

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

namespace rtm::comp {

// The longest one cycle takes, the budget of its timing contract (docs/timing.md): p99 47 us
// beside pa10-sim on these machines (docs/performance.md, "Timing contracts").
inline constexpr std::int64_t kActuatorBudgetNs = 50'000;

using rtm::pa10::FaultKind;
using rtm::pa10::VelocityArm;

struct ActuatorParams {
  // A watchdog longer than this is none: 1000 cycles are 2 s at 2 ms.
  static constexpr std::uint32_t kMaxWatchdogPeriods = 1000;
  // 30000 cycles are a minute at 2 ms.
  static constexpr std::uint32_t kMaxSensorRecoveryPeriods = 30000;
  // Cycles between fault resets while a force sensor node is silent (100 ms at 2 ms).
  static constexpr std::uint32_t kSensorRetryPeriods = 50;

  rtm::Param<std::array<float, 6>> limit{{0.05f, 0.05f, 0.05f, 0.3f, 0.3f, 0.3f},
                                         {"limit", "m/s, rad/s", "6 limits of |v|: vx vy vz, then wx wy wz",
                                          rtm::ParameterAccess::live, rtm::at_least(0)}};
  rtm::Param<std::uint32_t> watchdog_periods{
      3,
      {"watchdog_periods", "cycles", "cycles without a new command before the drives brake",
       rtm::ParameterAccess::when_off, rtm::between(1, kMaxWatchdogPeriods)}};
  // How long a force sensor node may stay silent, after its heartbeat loss was detected, before
  // the actuator gives up retrying (1000 cycles are 2 s at 2 ms).
  rtm::Param<std::uint32_t> sensor_recovery_periods{
      1000,
      {"sensor_recovery_periods", "cycles",
       "cycles a silent force sensor node is waited for (drives stopped) before the actuator fails",
       rtm::ParameterAccess::when_off, rtm::between(1, kMaxSensorRecoveryPeriods)}};

  // Throws std::invalid_argument for a negative or non-finite limit, watchdog_periods 0, or
  // sensor_recovery_periods out of [1, kMaxSensorRecoveryPeriods].
  void validate() const;
};

// The actuator's parameters (rtm/parameters.h); rtm-actuator and rtm-servo register their
// options with rtm::add_parameter_options.
const rtm::ParameterTable<ActuatorParams>& actuator_parameters();

// Fig. 7: each component clamped to [-limit[i], +limit[i]].
std::array<float, 6> clamp_twist(const std::array<float, 6>& limit, const RTM::Float6& command);

// What the actuator counts: each field is also the statistic of its name (`rtm cat`).
struct ActuatorCounters : rtm::CounterSet {
  rtm::Counter cycles{*this, "cycles", "cycles run"};
  rtm::Counter commands{*this, "commands", "new finite commands applied"};
  rtm::Counter clamped{*this, "clamped", "commands the limiter changed"};
  rtm::Counter watchdog_events{*this, "watchdog_events", "commands stopped arriving (quick stop)"};
  rtm::Counter non_finite_events{*this, "non_finite_events", "commands started holding NaN/inf (quick stop)"};
  rtm::Counter command_loss_recoveries{*this, "command_loss_recoveries", "drive RPDO timeouts reset and resumed from"};
  rtm::Counter cycle_owner_recoveries{*this, "cycle_owner_recoveries",
                                      "bus cycles the master took back from a late tick, reset and resumed from"};
  rtm::Counter feedback_gap_recoveries{*this, "feedback_gap_recoveries",
                                       "drives silent for a few SYNCs with their heartbeat on, reset and resumed from"};
  rtm::Counter not_ready_cycles{*this, "not_ready_cycles", "cycles the arm was not enabled (zero velocity)"};
  rtm::Counter sensor_heartbeat_losses{*this, "sensor_heartbeat_losses",
                                       "a force sensor node fell silent (drives stopped, retried)"};
  rtm::Counter sensor_heartbeat_recoveries{*this, "sensor_heartbeat_recoveries",
                                           "a silent force sensor node heard again within the budget"};
  rtm::Counter sensor_reset_attempts{*this, "sensor_reset_attempts",
                                     "fault resets tried while a force sensor node was silent"};
};

// Sample-to-drive latency, CLOCK_REALTIME, from the command stamp (the sensor sample's stamp,
// see the controller) to the moment the bus master wrote the RPDOs carrying that command
// (ArmDiagnostics::last_sent); 0 when the arm cannot tell. The statistics latency_p50 / _p99 /
// _max (us) and latency_samples.
struct ActuatorLatency {
  std::int64_t latency_p50_ns = 0;
  std::int64_t latency_p99_ns = 0;
  std::int64_t latency_max_ns = 0;
  std::uint64_t latency_samples = 0;
  // The earlier, shorter span: stamp to the twist handed to the arm (order_velocity returned);
  // the bus master sends it on its own cycle after that. The statistics handover_p50 / ...
  std::int64_t handover_p50_ns = 0;
  std::int64_t handover_p99_ns = 0;
  std::int64_t handover_max_ns = 0;
};

class Actuator final : public rtm::Component {
 public:
  // Feedback gaps resumed from (see recover_feedback_gap): this many within this many cycles
  // of each other.
  static constexpr std::uint32_t kMaxFeedbackGaps = 3;
  static constexpr std::uint64_t kFeedbackGapWindowCycles = 2500;

  Actuator(std::string name, std::unique_ptr<VelocityArm> arm, ActuatorParams params);

  void on_start() override;
  void on_cycle(const rtm::CycleContext& ctx) override;
  void on_stop() override;

  rtm::InPort<RTM::TimedFloat6>& command_in() { return command_in_; }
  rtm::OutPort<RTM::TimedFloat6>& pose_out() { return pose_out_; }
  VelocityArm& arm() { return *arm_; }
  // The parameters now (limit as last set, which the next cycle uses).
  ActuatorParams params() const;
  const ActuatorCounters& counters() const { return counters_; }
  ActuatorLatency latency() const;
  // The twist handed to the arm in the last cycle.
  std::array<float, 6> last_twist() const;

 private:
  void describe_self();
  // The measured pose to "pose", freshly stamped, when the arm can tell it.
  void write_pose();

  std::unique_ptr<VelocityArm> arm_;
  ActuatorParams params_;  // as on_start() took them: the periods change only while off
  rtm::LiveValue<ActuatorParams> params_live_{params_};  // as `rtm set` leaves them
  ActuatorParams cycle_params_ = params_;  // the cycle's copy: limit is live
  RTM::TimedFloat6 command_{};
  std::array<float, 6> twist_{};
  std::array<double, 6> measured_pose_{};
  RTM::TimedFloat6 pose_{};
  rtm::Freshness command_freshness_{params_.watchdog_periods};  // the watchdog; seen(): a command since on()
  bool command_bad_ = false;
  rtm::pa10::ArmDiagnostics::BusPosition last_command_bus_{};  // when the newest command was handed over
  std::array<std::atomic<float>, 6> last_twist_{};
  rtm::LatencyHistogram latency_;           // stamp -> RPDOs written
  rtm::LatencyHistogram handover_latency_;  // stamp -> handed to the arm
  // The last command handed over whose RPDO write is still to be seen (sequence 0 = none).
  std::uint64_t pending_sequence_ = 0;
  std::int64_t pending_stamp_ns_ = 0;
  void record_sent_latency();
  // A force sensor node's heartbeat loss, one cycle of it (faulted: the fault is latched, not
  // re-enabling after a reset): retry every kSensorRetryPeriods, give up after the budget
  // (throws).
  void retry_sensor_loss(bool faulted);
  void handle_arm_status(rtm::pa10::FaultKind status);
  // Resets the arm and moves again on the next new command only (command loss, a lost cycle
  // owner, a feedback gap), counting the event in `events`.
  void resume_after(rtm::Counter& events);
  // A drive's TPDOs stopped for the master's missed-feedback limit while its heartbeat went on
  // (a dead drive's heartbeat stops too: heartbeat_lost, an error): on the simulator a stall of
  // its process does that. Resumed from up to kMaxFeedbackGaps times within
  // kFeedbackGapWindowCycles of each other; one more is a drive that answers no SYNC (throws).
  void recover_feedback_gap();
  std::uint32_t feedback_gaps_in_window_ = 0;
  std::uint64_t last_feedback_gap_cycle_ = 0;
  bool in_sensor_loss_ = false;
  std::uint32_t sensor_loss_cycles_ = 0;
  std::uint32_t sensor_clear_cycles_ = 0;  // fault-free cycles in a row since the last retry
  static constexpr std::uint32_t kSensorClearCycles = 10;
  ActuatorCounters counters_;
  rtm::InPort<RTM::TimedFloat6>& command_in_ = add_in_port<RTM::TimedFloat6>(
      "twist", {"velocity command for the tool, base frame; clamped to ±limit",
                rtm::twist_elements()});
  rtm::OutPort<RTM::TimedFloat6>& pose_out_ = add_out_port<RTM::TimedFloat6>(
      "pose", {"tool pose the drives measure, base frame: position, rotation vector (axis * angle)",
               rtm::pose_elements()});
};

}  // namespace rtm::comp
