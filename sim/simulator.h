// Pa10Simulator: the PA10 scene and its nine CAN nodes (7 drives, wrist and joystick sensors)
// behind one frame interface; no transport, no clock of its own.
//
// The caller (pa10-sim's runner, or a test) owns the time:
//   - real time: call step() every timestep (1 ms) on an absolute schedule and on_frame() for
//     each frame as it arrives; a SYNC is answered at once with the current state;
//   - lock-step: call on_frame() only; each SYNC latches the drives' targets, advances the
//     physics by exactly one SYNC period (2 ms = 2 steps) and then answers (TPDOs).
// Bus time (heartbeats, the drives' command-loss check) is simulation time in both modes.
//
// power_on() first holds the arm still at the "ready" pose for a few steps to tare both force
// sensors (average of several samples), then boots every node (boot-up messages).
#pragma once

#include <linux/can.h>

#include <array>
#include <cstdint>
#include <memory>
#include <string>

#include "sim/drive_device.h"
#include "sim/force_sensor_device.h"
#include "sim/frame_sink.h"
#include "sim/operator_profile.h"
#include "sim/pa10_plant.h"

namespace rtm::sim {

struct SimulatorConfig {
  std::string scene_path;                        // the MJCF (sim/models/pa10_scene.xml)
  std::string initial_keyframe = "ready";
  std::int64_t sync_period_ns = 2'000'000;       // lock-step: physics advanced per SYNC
  int tare_samples = 20;                         // steps held still to tare the sensors
  ServoGains gains{};
  OperatorProfile operator_profile{};            // the joystick's wrench over sim time
};

class Pa10Simulator {
 public:
  explicit Pa10Simulator(SimulatorConfig config);  // throws SceneError

  // Tares the sensors, then sends the nodes' boot-up messages. Sim time starts at 0 after it.
  void power_on(FrameSink& out);

  enum class Mode : std::uint8_t { real_time, lock_step };
  void set_mode(Mode mode) { mode_ = mode; }
  Mode mode() const { return mode_; }

  // One frame from the (drive) bus; replies go to `out`. In lock-step a SYNC advances the
  // physics first. Without a separate sensor bus the sensors see these frames too.
  void on_frame(const can_frame& frame, FrameSink& out);

  // A separate sensor bus: from now on the sensors send to `sensor_out` and see only the
  // frames given to on_sensor_bus_frame() (a SYNC there is answered at once, never advances
  // the physics). nullptr goes back to one shared bus.
  void set_sensor_sink(FrameSink* sensor_out) { sensor_out_ = sensor_out; }
  void on_sensor_bus_frame(const can_frame& frame);

  // Real time: one physics step, the devices' clocks and heartbeats.
  void step(FrameSink& out);

  // Heartbeat of every node now (the runner beats on the wall clock in lock-step while no
  // SYNC flows).
  void send_heartbeats(FrameSink& out);

  // Replaces the operator's wrench from the profile by `wrench` (stdin control) until
  // clear_operator_override() gives the profile back.
  void set_operator_override(const Wrench& wrench);
  void clear_operator_override() { operator_override_ = false; }

  std::int64_t time_ns() const { return time_ns_; }
  std::uint64_t steps() const { return steps_; }
  Pa10Plant& plant() { return plant_; }
  const DriveDevice& drive(int joint) const { return drives_[static_cast<std::size_t>(joint)]; }
  const ForceSensorDevice& wrist_sensor() const { return wrist_; }
  const ForceSensorDevice& joystick_sensor() const { return joystick_; }

 private:
  void physics_step();
  void answer_sync(FrameSink& out);
  FrameSink& sensor_sink(FrameSink& out) { return sensor_out_ ? *sensor_out_ : out; }

  SimulatorConfig config_;
  Pa10Plant plant_;
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
