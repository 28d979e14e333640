// SPDX-License-Identifier: Apache-2.0
// Pa10Rig: the PA10's nine CAN nodes (7 drives, wrist and joystick force sensors) in front of
// a Plant, behind one frame interface; no transport, no clock of its own. pa10-sim runs it on
// the MuJoCo scene (Pa10Simulator), the CAN master's tests on a KinematicPlant (RigServer):
// the devices that answer the master in the tests are the ones the demo runs.
//
// The caller owns the time:
//   - real time: call step() every timestep (1 ms) on an absolute schedule and on_frame() for
//     each frame as it arrives; a SYNC is answered at once with the current state;
//   - lock-step: call on_frame() only; each SYNC latches the drives' targets, advances the
//     plant by exactly one SYNC period (2 ms = 2 steps) and then answers (TPDOs).
// Bus time (heartbeats, the drives' command-loss check) is rig time in both modes.
//
// power_on() first holds the arm still for a few steps to tare both force sensors (average of
// several samples), then boots every node (boot-up messages).
//
// The operator's hand on the joystick follows an OperatorProfile over rig time, or an
// override set from outside (pa10-sim's stdin, a test).
#pragma once

#include <linux/can.h>

#include <array>
#include <cstdint>
#include <stdexcept>

#include "sim/drive_device.h"
#include "sim/force_sensor_device.h"
#include "sim/frame_sink.h"
#include "sim/operator_profile.h"
#include "sim/plant.h"

namespace rtm::sim {

struct RigConfig {
  DriveConfig drive{};                           // every drive's, but its node id (1..7)
  std::int64_t sync_period_ns = 2'000'000;       // lock-step: plant advanced per SYNC
  int tare_samples = 20;                         // steps held still to tare the sensors
  OperatorProfile operator_profile{};            // the joystick's wrench over rig time
};

// The plant's timestep does not divide the SYNC period (lock-step could not advance by it).
class RigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Pa10Rig {
 public:
  // `plant` must outlive the rig. Throws RigError when the timestep does not divide the SYNC
  // period.
  Pa10Rig(Plant& plant, RigConfig config);

  // Tares the sensors, then sends the nodes' boot-up messages. Rig time starts at 0 after it.
  void power_on(FrameSink& out);

  enum class Mode : std::uint8_t { real_time, lock_step };
  void set_mode(Mode mode) { mode_ = mode; }
  Mode mode() const { return mode_; }

  // One frame from the (drive) bus; replies go to `out`. In lock-step a SYNC advances the
  // plant first. Without a separate sensor bus the sensors see these frames too.
  void on_frame(const can_frame& frame, FrameSink& out);

  // A separate sensor bus: from now on the sensors send to `sensor_out` and see only the
  // frames given to on_sensor_bus_frame() (a SYNC there is answered at once, never advances
  // the plant). nullptr goes back to one shared bus.
  void set_sensor_sink(FrameSink* sensor_out) { sensor_out_ = sensor_out; }
  void on_sensor_bus_frame(const can_frame& frame);

  // Real time: one plant step, the devices' clocks and heartbeats.
  void step(FrameSink& out);

  // Heartbeat of every node now (lock-step servers beat on the wall clock while no SYNC
  // flows).
  void send_heartbeats(FrameSink& out);

  // Replaces the operator's wrench from the profile by `wrench` until
  // clear_operator_override() gives the profile back.
  void set_operator_override(const Wrench& wrench);
  void clear_operator_override() { operator_override_ = false; }

  std::int64_t time_ns() const { return time_ns_; }
  std::uint64_t steps() const { return steps_; }
  std::int64_t timestep_ns() const { return timestep_ns_; }
  const DriveDevice& drive(int joint) const { return drives_[static_cast<std::size_t>(joint)]; }
  const ForceSensorDevice& wrist_sensor() const { return wrist_; }
  const ForceSensorDevice& joystick_sensor() const { return joystick_; }

  // The devices themselves, for fault injection (DriveDevice::inject_fault(), ...). Frames a
  // device sends then go to `out` (the sensors' to the sensor sink, if any).
  DriveDevice& drive(int joint) { return drives_[static_cast<std::size_t>(joint)]; }
  ForceSensorDevice& wrist_sensor() { return wrist_; }
  ForceSensorDevice& joystick_sensor() { return joystick_; }
  FrameSink& sensor_sink(FrameSink& out) { return sensor_out_ ? *sensor_out_ : out; }

 private:
  void plant_step();
  void latch_commands();
  void answer_sync(FrameSink& out);

  Plant& plant_;
  RigConfig config_;
  std::array<DriveDevice, kJointCount> drives_;
  ForceSensorDevice wrist_;
  ForceSensorDevice joystick_;
  FrameSink* sensor_out_ = nullptr;
  Mode mode_ = Mode::real_time;
  std::int64_t time_ns_ = 0;
  std::int64_t timestep_ns_ = 1'000'000;
  std::uint64_t steps_ = 0;
  bool operator_override_ = false;
  Wrench override_wrench_{};
};

}  // namespace rtm::sim
