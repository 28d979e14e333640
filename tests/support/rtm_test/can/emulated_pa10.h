// SPDX-License-Identifier: Apache-2.0
// The PA10's CAN nodes as pa10-sim emulates them (sim/pa10_rig.h: the same DriveDevice and
// ForceSensorDevice), on a kinematic plant (joint velocity integrates to position over 2 ms
// per SYNC, so lock-step results are exact), served on a bus from their own thread in
// lock-step (sim/rig_server.h). What the CAN master's tests and benchmarks drive.
//
// The accessors below read the devices and the plant under the server's lock; fault injection
// goes to the devices' own abilities (DriveDevice::inject_fault(), set_connected(), ...).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <set>
#include <string>

#include "arm/can/bus.h"
#include "arm/can/cia402.h"
#include "arm/can/master_types.h"
#include "arm/can/protocol.h"
#include "sim/kinematic_plant.h"
#include "sim/pa10_rig.h"
#include "sim/rig_server.h"

namespace rtm::can::testing {

struct EmulatedPa10Options {
  sim::RigConfig rig{};
  std::set<std::uint8_t> disconnected;  // cut off the bus from power-on: never boot, never answer
  std::string sensor_bus;               // the force sensors on this bus (empty: the same)
};

class EmulatedPa10 {
 private:
  template <class Read>
  auto read_drive(std::uint8_t drive, Read read) {
    return server_.with_rig([&](sim::Pa10Rig& rig, sim::FrameSink&) { return read(rig.drive(joint_index_of(drive))); });
  }

 public:
  using Options = EmulatedPa10Options;

  // Powers the nodes on (their boot-up messages go out) and serves `bus_spec`.
  explicit EmulatedPa10(const std::string& bus_spec, Options options = {})
      : rig_(plant_, options.rig),
        server_(rig_, open_bus(bus_spec),
                options.sensor_bus.empty() ? nullptr : open_bus(options.sensor_bus)) {
    for (std::uint8_t node : options.disconnected) set_connected(node, false);
    server_.start();
  }

  template <class F>
  decltype(auto) with_rig(F&& f) {
    return server_.with_rig(std::forward<F>(f));
  }

  // ---- what a test does to the nodes and the plant ----
  // The wrench the sensor measures: the wrist's contact wrench, or the operator's hand on the
  // joystick. {Fx, Fy, Fz, Tx, Ty, Tz}.
  void set_wrench(ForceSensor sensor, const std::array<double, 6>& values) {
    const sim::Wrench wrench{{values[0], values[1], values[2]}, {values[3], values[4], values[5]}};
    with_rig([&](sim::Pa10Rig& rig, sim::FrameSink&) {
      if (sensor == ForceSensor::wrist) plant_.set_wrist_wrench(wrench);
      else rig.set_operator_override(wrench);
    });
  }
  void inject_fault(std::uint8_t drive, std::uint16_t emcy_code = emcy::kDeviceHardware) {
    with_rig([&](sim::Pa10Rig& rig, sim::FrameSink& out) { rig.drive(joint_index_of(drive)).inject_fault(emcy_code, out); });
  }
  void set_fault_persistent(std::uint8_t drive) {
    with_rig([&](sim::Pa10Rig& rig, sim::FrameSink&) { rig.drive(joint_index_of(drive)).set_fault_persistent(true); });
  }
  void set_connected(std::uint8_t node, bool connected) {
    server_.with_rig([&](sim::Pa10Rig& rig, sim::FrameSink&) {
      if (node == kWristSensorNode) rig.wrist_sensor().set_connected(connected);
      else if (node == kJoystickSensorNode) rig.joystick_sensor().set_connected(connected);
      else rig.drive(joint_index_of(node)).set_connected(connected);
    });
  }
  // The drive's joint moves at this velocity whatever it is commanded (KinematicPlant).
  void set_runaway_velocity(std::uint8_t drive, double velocity_rad_s) {
    with_rig([&](sim::Pa10Rig&, sim::FrameSink&) { plant_.set_runaway_velocity(joint_index_of(drive), velocity_rad_s); });
  }
  void lose_next_tpdo(std::uint8_t drive) {
    with_rig([&](sim::Pa10Rig& rig, sim::FrameSink&) { rig.drive(joint_index_of(drive)).lose_next_tpdos(1); });
  }
  void lose_next_rpdos(std::uint8_t drive, int count) {
    with_rig([&](sim::Pa10Rig& rig, sim::FrameSink&) { rig.drive(joint_index_of(drive)).lose_next_rpdos(count); });
  }

  // ---- observations ----
  DriveState drive_state(std::uint8_t drive) {
    return read_drive(drive, [](const sim::DriveDevice& d) { return d.drive_state(); });
  }
  double latched_velocity_rad_s(std::uint8_t drive) {
    return read_drive(drive, [](const sim::DriveDevice& d) { return d.target_velocity_rad_s(); });
  }
  std::uint16_t latched_controlword(std::uint8_t drive) {
    return read_drive(drive, [](const sim::DriveDevice& d) { return d.controlword(); });
  }
  std::int8_t mode_of_operation(std::uint8_t drive) {
    return read_drive(drive, [](const sim::DriveDevice& d) { return d.mode_of_operation(); });
  }
  NmtState nmt_state(std::uint8_t node) {
    return with_rig([&](sim::Pa10Rig& rig, sim::FrameSink&) {
      if (node == kWristSensorNode) return static_cast<NmtState>(rig.wrist_sensor().nmt_state());
      if (node == kJoystickSensorNode) return static_cast<NmtState>(rig.joystick_sensor().nmt_state());
      return static_cast<NmtState>(rig.drive(joint_index_of(node)).nmt_state());
    });
  }
  // The plant's joint position (what the drive reports in its next TPDO).
  double position_rad(std::uint8_t drive) {
    return with_rig([&](sim::Pa10Rig&, sim::FrameSink&) { return plant_.joint_state(joint_index_of(drive)).position_rad; });
  }
  // SYNCs drive 1 has seen, and the counter of the last one.
  std::uint64_t syncs_seen() {
    return read_drive(drive_node(0), [](const sim::DriveDevice& d) { return d.syncs_seen(); });
  }
  std::uint8_t last_sync_counter() {
    return read_drive(drive_node(0), [](const sim::DriveDevice& d) { return d.last_sync_counter(); });
  }
  std::uint8_t last_sensor_sync_counter(ForceSensor sensor) {
    return with_rig([&](sim::Pa10Rig& rig, sim::FrameSink&) {
      return sensor == ForceSensor::wrist ? rig.wrist_sensor().last_sync_counter()
                                          : rig.joystick_sensor().last_sync_counter();
    });
  }

 private:

  sim::KinematicPlant plant_;
  sim::Pa10Rig rig_;
  sim::RigServer server_;
};

}  // namespace rtm::can::testing
