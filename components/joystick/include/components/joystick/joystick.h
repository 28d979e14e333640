// SPDX-License-Identifier: Apache-2.0
// Joystick: the reference generator (paper Fig. 5's twin). A second 6-axis force sensor that
// the operator pushes; the force applied is the reference, written each cycle to OutPort 0
// ("reference", alias "out0", RTM::TimedFloat6). Statistic: samples.
//
// Sign and frame: the joystick's sensor frame is aligned with the arm's base frame
// (sim/profiles: x forward, z up), and it reports the force the operator applies to the
// handle. So the value is already in the base frame: pushing the handle down reads -Fz, a
// downward reference; the controller's gain*(ref + sen) then drives the tool down until the
// table's reaction (+Fz at the wrist) balances it.
#pragma once

#include "arm/can/master.h"
#include "arm/can/sensor_listener.h"
#include "rtm/component.h"

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

namespace rtm::comp {

// The newest joystick wrench (Fx Fy Fz N, Tx Ty Tz N·m, base-aligned frame).
struct JoystickReading {
  std::array<double, 6> wrench{};
  std::uint64_t sequence = 0;  // grows with each new wrench
  bool valid = false;
};

// The hardware seam of the Joystick component. Its faults are the arm library's one vocabulary
// (arm/can/fault.h), as the joystick node gives them: heartbeat_lost (silent; clears by itself
// when the node is heard again), emergency (the sensor's own EMCY), bus_error.
class JoystickSource {
 public:
  virtual ~JoystickSource() = default;
  virtual JoystickReading latest() const = 0;  // never blocks
  // The kind of fault now; allocates nothing (asked each cycle in which nothing new came).
  virtual rtm::can::FaultKind fault_kind() const = 0;
  // The fault now with its sentence (may allocate: asked when the kind is not none).
  virtual rtm::can::Fault fault() const = 0;
};

// Reads the Pa10Master of this process (it listens to the joystick node too).
class MasterJoystickSource final : public JoystickSource {
 public:
  explicit MasterJoystickSource(const rtm::can::Pa10Master& master) : master_(master) {}
  JoystickReading latest() const override;
  // The master's faults are the actuator's: the joystick node's silence stops the arm there.
  rtm::can::FaultKind fault_kind() const override { return rtm::can::FaultKind::none; }
  rtm::can::Fault fault() const override { return {}; }

 private:
  const rtm::can::Pa10Master& master_;
};

// A passive listener on the joystick's bus (its own process). Throws rtm::can::BusError.
class BusJoystickSource final : public JoystickSource {
 public:
  explicit BusJoystickSource(std::string_view bus_spec);
  JoystickReading latest() const override;
  rtm::can::FaultKind fault_kind() const override { return listener_.fault_kind(); }
  rtm::can::Fault fault() const override { return listener_.fault(); }

 private:
  rtm::can::SensorListener listener_;
};

// What the joystick counts: each field is also the statistic of its name (`rtm cat`).
struct JoystickCounters : rtm::CounterSet {
  rtm::Counter samples{*this, "samples", "reference wrenches written"};
  rtm::Counter heartbeat_losses{*this, "heartbeat_losses",
                                "the joystick node's heartbeat went silent (nothing written meanwhile)"};
  rtm::Counter heartbeat_recoveries{*this, "heartbeat_recoveries",
                                    "... and it was heard again with a new wrench within the budget"};
};

class Joystick final : public rtm::Component {
 public:
  // A silent joystick node (a host stall of the simulator, a loose cable) is waited out this
  // many cycles, writing nothing (the controller's reference goes stale and the arm brakes);
  // heard again with a newer wrench, the joystick writes again. Longer: an error.
  static constexpr std::uint32_t kHeartbeatRecoveryPeriods = 1000;

  Joystick(std::string name, std::unique_ptr<JoystickSource> source);

  void on_start() override;
  // Writes each new wrench once, stamped with the time it was read.
  void on_cycle(const rtm::CycleContext& ctx) override;

  rtm::OutPort<RTM::TimedFloat6>& out() { return out_; }
  const JoystickCounters& counters() const { return counters_; }

 private:
  // Nothing new came: the source's fault, if any, starts a heartbeat loss or is thrown.
  void check_fault(const JoystickReading& reading);
  // In a loss: true once the node is heard again with a wrench newer than the loss.
  bool back_from_loss(const JoystickReading& reading, bool fresh);

  std::unique_ptr<JoystickSource> source_;
  std::uint64_t last_sequence_ = 0;
  bool lost_ = false;
  std::uint32_t lost_cycles_ = 0;
  std::uint64_t loss_sequence_ = 0;
  RTM::TimedFloat6 datum_{};
  JoystickCounters counters_;
  rtm::OutPort<RTM::TimedFloat6>& out_ = add_out_port<RTM::TimedFloat6>(
      "reference", {"reference wrench: the operator's force, base frame",
                    rtm::wrench_elements()});
};

}  // namespace rtm::comp
