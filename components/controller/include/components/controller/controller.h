// Controller: the paper's proportional force controller (Fig. 6).
//
//   InPort 0 "wrench"     (alias in0)  sensor wrench     (TimedFloat6, base frame, N / N·m)
//   InPort 1 "reference"  (alias in1)  reference wrench  (TimedFloat6, base frame, N / N·m)
//   OutPort 0 "twist"     (alias out0) velocity command  (TimedFloat6, base frame, m/s / rad/s)
//
// Parameters: gain (live: the next cycle uses it), stale_periods (while off). Statistics:
// the ControllerCounters, by name.
//
// Each cycle out[i] = gain[i] * (ref[i] + sen[i]). The plus is the paper's: the hand sensor
// reads the reaction force, opposite in sign to the reference, so the command is zero when
// they balance. While an input has had no new datum for stale_periods cycles, or holds NaN/inf,
// no command is written at all (never the last one, never a zero one): the actuator's watchdog
// then brakes the drives, as when the controller itself is lost. A command's stamp is the
// stamp of the sensor sample it was computed from, so a receiver can measure sample-to-drive
// latency.
#pragma once

#include "rtm/component.h"
#include "rtm/freshness.h"
#include "rt/live_value.h"

#include <array>
#include <atomic>
#include <cstdint>
#include <string>

namespace CLI {
class App;
}

namespace rtm::comp {

struct ControllerParams {
  // (m/s)/N for x y z, (rad/s)/(N·m) for the rotations. With the PA10's drive loops
  // (pa10-sim: 25 rad/s velocity bandwidth, kv = 20) 0.002..0.007 m/(s·N) press stably on the table.
  std::array<float, 6> gain{0.003f, 0.003f, 0.003f, 0.0f, 0.0f, 0.0f};
  std::uint32_t stale_periods = 3;  // cycles without a new datum before an input is stale

  // Throws std::invalid_argument naming the bad value (NaN/inf gain, stale_periods 0).
  void validate() const;
  // Registers --gain and --stale-periods on app, bound to these fields (rtm-controller and
  // rtm-servo share them); call validate() after parsing.
  void add_options(CLI::App& app);
};

// Fig. 6: out[i] = gain[i] * (ref[i] + sen[i]).
std::array<float, 6> proportional_command(const std::array<float, 6>& gain, const RTM::Float6& reference,
                                          const RTM::Float6& sensor);

struct ControllerCounters {
  std::uint64_t cycles = 0;
  std::uint64_t commands = 0;         // proportional commands written
  std::uint64_t withheld = 0;         // cycles without a command (stale, missing or bad input)
  std::uint64_t stale_events = 0;     // an input went stale after having been fresh
  std::uint64_t non_finite_events = 0;  // an input started holding NaN/inf
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
  ControllerCounters counters() const;

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

  ControllerParams params_;  // stale_periods changes only while off; gain through gain_live_
  rtm::LiveValue<std::array<float, 6>> gain_live_{params_.gain};
  Input sensor_{params_.stale_periods};
  Input reference_{params_.stale_periods};
  RTM::TimedFloat6 command_{};
  std::array<float, 6> gain_ = params_.gain;  // the cycle's copy of gain_live_
  std::atomic<std::uint64_t> cycles_{0}, commands_{0}, withheld_commands_{0}, stale_events_{0}, non_finite_events_{0};
  rtm::InPort<RTM::TimedFloat6>& sensor_in_ = add_in_port<RTM::TimedFloat6>(
      "wrench", {"wrench the sensor measures, base frame", rtm::wrench_elements()});
  rtm::InPort<RTM::TimedFloat6>& reference_in_ = add_in_port<RTM::TimedFloat6>(
      "reference", {"reference wrench, base frame", rtm::wrench_elements()});
  rtm::OutPort<RTM::TimedFloat6>& command_out_ = add_out_port<RTM::TimedFloat6>(
      "twist", {"velocity command gain*(reference + wrench), base frame",
                rtm::twist_elements()});
};

}  // namespace rtm::comp
