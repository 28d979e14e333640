// SPDX-License-Identifier: Apache-2.0
#include "sim/pa10_rig.h"

#include <cmath>
#include <string>
#include <utility>

#include "arm/can/protocol.h"

namespace rtm::sim {

namespace pc = rtm::can;

namespace {

std::array<DriveDevice, kJointCount> make_drives(const DriveConfig& common) {
  auto drive = [&](int joint) {
    DriveConfig config = common;
    config.node_id = pc::drive_node(joint);
    return DriveDevice(config);
  };
  return {drive(0), drive(1), drive(2), drive(3), drive(4), drive(5), drive(6)};
}

ForceSensorConfig sensor_config(std::uint8_t node, int tare_samples) {
  ForceSensorConfig config;
  config.node_id = node;
  config.tare_samples = tare_samples;
  return config;
}

}  // namespace

Pa10Rig::Pa10Rig(Plant& plant, RigConfig config)
    : plant_(plant),
      config_(std::move(config)),
      drives_(make_drives(config_.drive)),
      wrist_(sensor_config(pc::kWristSensorNode, config_.tare_samples)),
      joystick_(sensor_config(pc::kJoystickSensorNode, config_.tare_samples)) {
  timestep_ns_ = std::llround(plant_.timestep_s() * 1e9);
  if (timestep_ns_ <= 0 || config_.sync_period_ns % timestep_ns_ != 0)
    throw RigError("the plant's timestep (" + std::to_string(timestep_ns_) +
                   " ns) must divide the SYNC period (" + std::to_string(config_.sync_period_ns) +
                   " ns)");
}

void Pa10Rig::power_on(FrameSink& out) {
  // The arm holds still on its brakes while the sensors settle and are tared; the operator
  // keeps off the joystick meanwhile.
  plant_.set_operator_wrench({});
  for (int i = 0; i < config_.tare_samples; ++i) {
    plant_.step();
    wrist_.add_tare_sample(plant_.wrist_wrench());
    joystick_.add_tare_sample(plant_.joystick_wrench());
  }
  time_ns_ = 0;
  steps_ = 0;
  for (auto& drive : drives_) drive.power_on(time_ns_, out);
  wrist_.power_on(time_ns_, sensor_sink(out));
  joystick_.power_on(time_ns_, sensor_sink(out));
}

void Pa10Rig::set_operator_override(const Wrench& wrench) {
  operator_override_ = true;
  override_wrench_ = wrench;
}

void Pa10Rig::latch_commands() {
  for (int j = 0; j < kJointCount; ++j)
    plant_.set_command(j, drives_[static_cast<std::size_t>(j)].command());
}

void Pa10Rig::plant_step() {
  const double t_s = static_cast<double>(time_ns_) * 1e-9;
  plant_.set_operator_wrench(operator_override_ ? override_wrench_
                                                : config_.operator_profile.wrench_at(t_s));
  latch_commands();
  plant_.step();
  time_ns_ += timestep_ns_;
  ++steps_;
}

void Pa10Rig::step(FrameSink& out) {
  plant_step();
  for (auto& drive : drives_) drive.tick(time_ns_, out);
  wrist_.tick(time_ns_, sensor_sink(out));
  joystick_.tick(time_ns_, sensor_sink(out));
}

void Pa10Rig::on_frame(const can_frame& frame, FrameSink& out) {
  for (auto& drive : drives_) drive.on_frame(frame, time_ns_, out);
  if (!sensor_out_) {
    wrist_.on_frame(frame, time_ns_, out);
    joystick_.on_frame(frame, time_ns_, out);
  }
  if (pc::classify(frame).type != pc::FrameType::sync || !pc::decode_sync(frame).ok()) return;
  if (mode_ == Mode::lock_step) {
    for (std::int64_t advanced_ns = 0; advanced_ns < config_.sync_period_ns;
         advanced_ns += timestep_ns_)
      step(out);
  } else {
    latch_commands();  // targets latched at this SYNC act from the next step on
  }
  answer_sync(out);
}

void Pa10Rig::on_sensor_bus_frame(const can_frame& frame) {
  if (!sensor_out_) return;
  wrist_.on_frame(frame, time_ns_, *sensor_out_);
  joystick_.on_frame(frame, time_ns_, *sensor_out_);
  wrist_.send_tpdo(plant_.wrist_wrench(), *sensor_out_);
  joystick_.send_tpdo(plant_.joystick_wrench(), *sensor_out_);
}

void Pa10Rig::answer_sync(FrameSink& out) {
  for (int j = 0; j < kJointCount; ++j)
    drives_[static_cast<std::size_t>(j)].send_tpdo(plant_.joint_state(j), out);
  wrist_.send_tpdo(plant_.wrist_wrench(), sensor_sink(out));
  joystick_.send_tpdo(plant_.joystick_wrench(), sensor_sink(out));
}

void Pa10Rig::send_heartbeats(FrameSink& out) {
  for (auto& drive : drives_) drive.send_heartbeat(out);
  wrist_.send_heartbeat(sensor_sink(out));
  joystick_.send_heartbeat(sensor_sink(out));
}

}  // namespace rtm::sim
