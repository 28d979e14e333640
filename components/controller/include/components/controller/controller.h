// SPDX-License-Identifier: Apache-2.0
// Controller: the paper's proportional force controller (Fig. 6), with a bounded touch-down.
//
//   InPort 0 "wrench"     (alias in0)  sensor wrench     (TimedFloat6, base frame, N / N·m)
//   InPort 1 "reference"  (alias in1)  reference wrench  (TimedFloat6, base frame, N / N·m)
//   OutPort 0 "twist"     (alias out0) velocity command  (TimedFloat6, base frame, m/s / rad/s)
//
// Parameters: gain, free_gain, approach_speed, contact_force (live: the next cycle uses them),
// stale_periods (while off). Statistics: the ControllerCounters, by name.
//
// Each cycle out[i] = gain[i] * (ref[i] + sen[i]). The plus is the paper's: the hand sensor
// reads the reaction force, opposite in sign to the reference, so the command is zero when
// they balance. While an input has had no new datum for stale_periods cycles, or holds NaN/inf,
// no command is written at all (never the last one, never a zero one): the actuator's watchdog
// then brakes the drives, as when the controller itself is lost. A command's stamp is the
// stamp of the sensor sample it was computed from, so a receiver can measure sample-to-drive
// latency.
//
// The bounded touch-down (beyond the paper; approach_speed 0 turns it off and leaves the
// paper's P alone). A gain that keeps a force loop stable on a stiff surface is far too small
// for moving in free space, and a gain that moves briskly hits the surface too fast to stop
// before the force overshoots. So the controller tells contact from free space by the measured
// force: in contact (|force| has reached contact_force, until it stays below half of it for
// 20 ms) it is the
// paper's P with `gain`; in free space it commands free_gain * (ref + sen) with the
// translational speed limited to approach_speed (the vector scaled, its direction kept), so
// the tool meets a surface at most that fast, whatever the operator asks. Choose
// approach_speed near gain * the pressing force: the contact loop then takes over the motion
// without a jump.
#pragma once

#include "rtm/component.h"
#include "rtm/freshness.h"
#include "rt/live_value.h"

#include <array>
#include <atomic>
#include <cstdint>
#include <string>

namespace rtm::comp {

// The longest one cycle takes, the budget of its timing contract (docs/timing.md): p99 21 us in
// the demo on these machines, 34 us beside a -j2 build (docs/performance.md, "Timing contracts").
inline constexpr std::int64_t kControllerBudgetNs = 50'000;

struct ControllerParams {
  // The contact gain. On pa10-sim's default steel surface (10^5 N/m, 400 rad/s drives) the
  // largest stable gain is 0.00066 with the paper's five processes and 0.0012 on the shared
  // tick (bench/sim/stability_study); the default keeps a margin below both.
  rtm::Param<std::array<float, 6>> gain{{0.0004f, 0.0004f, 0.0004f, 0.0f, 0.0f, 0.0f},
                                        {"gain", "(m/s)/N, (rad/s)/(N·m)", "6 gains in contact: x y z, then rx ry rz",
                                         rtm::ParameterAccess::live}};
  // The bounded touch-down (see above); approach_speed 0: the paper's P everywhere.
  rtm::Param<std::array<float, 6>> free_gain{
      {0.003f, 0.003f, 0.003f, 0.0f, 0.0f, 0.0f},
      {"free_gain", "(m/s)/N, (rad/s)/(N·m)", "6 gains in free space while approach_speed is on: x y z, then rx ry rz",
       rtm::ParameterAccess::live}};
  rtm::Param<float> approach_speed_m_s{
      0.005f,
      {"approach_speed", "m/s",
       "free-space speed limit, so the tool meets a surface at most this fast; 0: the paper's plain P (gain "
       "everywhere)",
       rtm::ParameterAccess::live, rtm::at_least(0)}};
  rtm::Param<float> contact_force_N{
      1.0f,
      {"contact_force", "N", "|force| from which the tool is in contact (left after 10 cycles below half of it)",
       rtm::ParameterAccess::live, rtm::above(0)}};
  rtm::Param<std::uint32_t> stale_periods{
      3,
      {"stale_periods", "cycles", "cycles without a new input datum before the command is withheld (the actuator brakes)",
       rtm::ParameterAccess::when_off, rtm::between(1, 1'000'000)}};

  // Throws std::invalid_argument naming the bad value (NaN/inf gain, a negative approach
  // speed, a contact force not above 0, stale_periods 0), as the fields' bounds say.
  void validate() const;
};

// The controller's parameters (rtm/parameters.h): its options (an executable registers them
// with rtm::add_parameter_options; rtm-controller and rtm-servo both do), their help and
// bounds, what `rtm cat` shows and `rtm set` changes.
const rtm::ParameterTable<ControllerParams>& controller_parameters();

// Fig. 6: out[i] = gain[i] * (ref[i] + sen[i]).
std::array<float, 6> proportional_command(const std::array<float, 6>& gain, const RTM::Float6& reference,
                                          const RTM::Float6& sensor);

// Contact, judged from the measured force (sensor x y z): entered when its magnitude reaches
// contact_force_N, left when it has stayed below half of that for kLiftOffCycles cycles in a
// row. The hysteresis keeps a force near the threshold from toggling the gain every cycle, the
// delay keeps the tool's brief bounce after an impact (a few ms) inside the contact.
class ContactDetector {
 public:
  static constexpr std::uint32_t kLiftOffCycles = 10;
  // The state after this cycle's sensor reading.
  bool update(const RTM::Float6& sensor, float contact_force_N);
  bool in_contact() const { return contact_; }

 private:
  bool contact_ = false;
  std::uint32_t cycles_below_ = 0;
};

// The bounded touch-down's command: in contact the paper's P with gain; in free space
// free_gain * (ref + sen), its translational part scaled down to approach_speed_m_s when
// faster (slowed: whether it was). approach_speed_m_s 0: the paper's P with gain, contact or not.
struct GuardedCommand {
  std::array<float, 6> twist{};
  bool slowed = false;
};
GuardedCommand guarded_command(const ControllerParams& params, bool contact, const RTM::Float6& reference,
                               const RTM::Float6& sensor);

// What the controller counts: each field is also the statistic of its name (`rtm cat`).
struct ControllerCounters : rtm::CounterSet {
  rtm::Counter cycles{*this, "cycles", "cycles run"};
  rtm::Counter commands{*this, "commands", "proportional commands written"};
  rtm::Counter withheld_commands{*this, "withheld_commands",
                                 "cycles without a command (stale, missing or bad input): the actuator brakes"};
  rtm::Counter stale_events{*this, "stale_events", "an input went stale after having been fresh"};
  rtm::Counter non_finite_events{*this, "non_finite_events", "an input started holding NaN/inf"};
  rtm::Counter touch_downs{*this, "touch_downs", "free space -> contact (|force| reached contact_force)"};
  rtm::Counter lift_offs{*this, "lift_offs", "contact -> free space (|force| below half of contact_force for 10 cycles)"};
  rtm::Counter approach_limited{*this, "approach_limited", "free-space commands slowed to approach_speed"};
};

class Controller final : public rtm::Component {
 public:
  Controller(std::string name, ControllerParams params);

  void on_start() override;
  void on_cycle(const rtm::CycleContext& ctx) override;

  rtm::InPort<RTM::TimedFloat6>& sensor_in() { return sensor_in_; }
  rtm::InPort<RTM::TimedFloat6>& reference_in() { return reference_in_; }
  rtm::OutPort<RTM::TimedFloat6>& command_out() { return command_out_; }
  // The parameters now (gain as last set, which the next cycle uses).
  ControllerParams params() const;
  const ControllerCounters& counters() const { return counters_; }

 private:
  // One input's newest datum; fresh for stale_periods cycles after it came.
  struct Input {
    explicit Input(std::uint32_t stale_periods) : freshness(stale_periods) {}
    RTM::TimedFloat6 datum{};
    rtm::Freshness freshness;
    bool was_bad = false;
  };
  // Reads the port's newest datum into input; returns what that did to its freshness.
  rtm::Freshness::Change update(rtm::InPort<RTM::TimedFloat6>& port, Input& input);
  bool usable(Input& input, rtm::Freshness::Change change, const char* what);
  void describe_self();
  void take_live_parameters();

  ControllerParams params_;  // as on_start() took them: stale_periods changes only while off
  rtm::LiveValue<ControllerParams> params_live_{params_};  // as `rtm set` leaves them
  ControllerParams cycle_params_ = params_;  // the cycle's copy of the live parameters
  ContactDetector contact_;
  Input sensor_{params_.stale_periods};
  Input reference_{params_.stale_periods};
  RTM::TimedFloat6 command_{};
  ControllerCounters counters_;
  rtm::InPort<RTM::TimedFloat6>& sensor_in_ = add_in_port<RTM::TimedFloat6>(
      "wrench", {"wrench the sensor measures, base frame", rtm::wrench_elements()});
  rtm::InPort<RTM::TimedFloat6>& reference_in_ = add_in_port<RTM::TimedFloat6>(
      "reference", {"reference wrench, base frame", rtm::wrench_elements()});
  rtm::OutPort<RTM::TimedFloat6>& command_out_ = add_out_port<RTM::TimedFloat6>(
      "twist", {"velocity command gain*(reference + wrench), base frame",
                rtm::twist_elements()});
};

}  // namespace rtm::comp
