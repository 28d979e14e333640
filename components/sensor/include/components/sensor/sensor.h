// SPDX-License-Identifier: Apache-2.0
// Sensor: a 6-axis force/torque sensor of the arm's bus as an RT component, one class for both
// of the system's: the wrist sensor (paper Fig. 5) and the operator's joystick (its twin, the
// reference generator). The node is its one difference, and it sets the rest:
//
//   node      kind      OutPort 0 (alias out0)  frame of what it writes
//   wrist     sensor    "wrench"                base: rotated with the forward kinematics of
//                                               the joint positions heard on the bus
//   joystick  joystick  "reference"             base: the joystick's frame is base-aligned
//
// Each cycle it takes the newest wrench, stamps the time and writes it (RTM::TimedFloat6), only
// once per wrench. Statistics: samples, heartbeat_losses, heartbeat_recoveries. Parameter:
// recovery_timeout_periods (while off).
//
// Faults of the source (ForceSource::fault()):
//   - heartbeat_lost (the node silent longer than its heartbeat timeout, e.g. a pulled cable,
//     or the simulator's process stalled): the component writes nothing (no stale or zero
//     datum: the controller sees its input go stale, withholds its command, and the actuator's
//     watchdog brakes; a master that watches the node itself latches its own fault, see
//     docs/safety.md), counts the event and logs it once. When the node's heartbeat is back
//     and a wrench newer than the loss arrives, it writes again, counting and logging the
//     recovery once. A node not back within recovery_timeout_periods cycles of the loss puts
//     the component in COMPONENT_ERROR with a reason naming the node and how long it was silent;
//   - emergency (an EMCY with a non-zero code) or bus_error: COMPONENT_ERROR at once.
//
// Sign and frame (what the controller's gain*(ref + sen) relies on): the wrist's value is the
// wrench the outside world exerts on the tool, in the BASE frame (N, N·m, torque about the
// sensor origin). Pressing the tool down on the table therefore reads +Fz (the table pushes
// up). The sim's sensor (sim/pa10_plant.cpp, site wrist_ft) reports exactly that wrench in the
// sensor frame, whose axes are those of the URDF's tool0 (ft_sensor_to_tool0 has no rotation);
// so wrench_base = R_base_tool0(q) * wrench_sensor. The joystick reports the force the operator
// applies to the handle, in a frame aligned with the base (sim/profiles: x forward, z up):
// pushing the handle down reads -Fz, a downward reference; gain*(ref + sen) then drives the
// tool down until the table's reaction (+Fz at the wrist) balances it.
#pragma once

#include "components/sensor/force_source.h"

#include "arm/pa10/kinematics.h"
#include "rtm/component.h"

#include <Eigen/Core>

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

namespace rtm::comp {

// The longest one cycle takes, the budget of its timing contract (docs/timing.md): the wrist's
// (which turns the wrench into the base frame) p99 87 us, the joystick's 58 us, in the demo on
// these machines (docs/performance.md, "Timing contracts").
inline constexpr std::int64_t kWristSensorBudgetNs = 100'000;
inline constexpr std::int64_t kJoystickBudgetNs = 60'000;

struct SensorParams {
  // 30000 cycles are a minute at 2 ms: a sensor silent that long is not coming back by itself.
  static constexpr std::uint32_t kMaxRecoveryTimeoutPeriods = 30000;
  // Counted from the moment the loss is seen (the node's heartbeat timeout after its last
  // heartbeat): 1000 cycles are 2 s at 2 ms.
  rtm::Param<std::uint32_t> recovery_timeout_periods{
      1000,
      {"recovery_timeout_periods", "cycles",
       "cycles a heartbeat loss of the sensor node may last before the component goes to error",
       rtm::ParameterAccess::when_off, rtm::between(1, kMaxRecoveryTimeoutPeriods)}};

  // Throws std::invalid_argument naming the bad value (recovery_timeout_periods 0 or above the
  // maximum).
  void validate() const;
};

// The sensor's parameter (rtm/parameters.h); rtm-sensor registers its option with
// rtm::add_parameter_options.
const rtm::ParameterTable<SensorParams>& sensor_parameters();

// What the sensor counts: each field is also the statistic of its name (`rtm cat`).
struct SensorCounters : rtm::CounterSet {
  rtm::Counter samples{*this, "samples", "wrenches written"};
  rtm::Counter heartbeat_losses{*this, "heartbeat_losses",
                                "the sensor node's heartbeat went silent (nothing written meanwhile)"};
  rtm::Counter heartbeat_recoveries{*this, "heartbeat_recoveries",
                                    "the sensor node came back with fresh wrenches in time, writing resumed"};
};

// wrench_sensor (Fx Fy Fz Tx Ty Tz, sensor frame) rotated into the base frame, given the
// rotation base <- sensor.
std::array<double, 6> wrench_sensor_to_base(const Eigen::Matrix3d& rotation_base_sensor,
                                            const std::array<double, 6>& wrench_sensor);

class Sensor final : public rtm::Component {
 public:
  // The wrist sensor. kinematics: the arm model (e.g. Kinematics::pa10()), chain
  // base_link -> tool0. Throws std::invalid_argument for a missing source or bad params.
  static std::unique_ptr<Sensor> wrist(std::string name, std::unique_ptr<ForceSource> source,
                                       rtm::pa10::Kinematics kinematics, SensorParams params = {});
  // The operator's joystick. Throws std::invalid_argument for a missing source or bad params.
  static std::unique_ptr<Sensor> joystick(std::string name, std::unique_ptr<ForceSource> source,
                                          SensorParams params = {});
  // kinematics: required for the wrist (std::invalid_argument without), unused for the joystick.
  Sensor(std::string name, rtm::can::ForceSensor node, std::unique_ptr<ForceSource> source,
         std::optional<rtm::pa10::Kinematics> kinematics, SensorParams params = {});

  // Writes a datum only for a wrench not written before. A source fault, asked only in a
  // cycle without a new wrench, is handled as described at the top: a heartbeat loss is
  // waited out within the budget, anything else throws (COMPONENT_ERROR with the reason).
  void on_cycle(const rtm::CycleContext& ctx) override;
  void on_start() override;

  rtm::OutPort<RTM::TimedFloat6>& out() { return out_; }
  rtm::can::ForceSensor node() const { return node_; }
  const SensorCounters& counters() const { return counters_; }
  SensorParams params() const { return params_live_.published(); }
  // In a heartbeat loss now (nothing is written).
  bool in_heartbeat_loss() const { return lost_flag_.load(std::memory_order_relaxed); }

 private:
  void write(const ForceSample& sample);
  // A sample not written before, with what writing it needs (the wrist: the joints).
  bool fresh(const ForceSample& sample) const {
    return sample.valid && sample.sequence != last_sequence_ && (!kinematics_ || sample.q_valid);
  }
  void begin_loss(const Fault& fault, std::int64_t period_ns);
  [[noreturn]] void give_up(std::int64_t period_ns) const;

  rtm::can::ForceSensor node_;
  std::unique_ptr<ForceSource> source_;
  std::optional<rtm::pa10::Kinematics> kinematics_;  // the wrist's: its frame turned into the base's
  SensorParams params_;  // as on_start() took them: recovery_timeout_periods changes only while off
  rtm::LiveValue<SensorParams> params_live_{params_};  // as `rtm set` leaves them
  std::uint32_t recovery_budget_ = params_.recovery_timeout_periods;  // the cycle's copy (on_start)
  rtm::pa10::JointVector q_rad_ = rtm::pa10::JointVector::Zero();
  std::uint64_t last_sequence_ = 0;
  RTM::TimedFloat6 datum_{};
  // The heartbeat loss under way: its cycles so far, the newest wrench sequence when it was
  // seen (only a later one resumes writing) and its text for the log and the final reason.
  bool lost_ = false;
  std::uint32_t lost_cycles_ = 0;
  std::uint64_t loss_sequence_ = 0;
  std::string loss_reason_;
  std::atomic<bool> lost_flag_{false};
  SensorCounters counters_;
  rtm::OutPort<RTM::TimedFloat6>& out_;
};

}  // namespace rtm::comp
