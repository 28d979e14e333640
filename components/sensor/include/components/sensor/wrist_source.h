// SPDX-License-Identifier: Apache-2.0
// Where the Sensor component gets its samples: the wrist F/T sensor's wrench (sensor frame)
// together with the joint positions that say how the sensor frame is oriented.
//
// Two sources behind one small seam, so the component never knows which one it reads:
//   MasterWristSource  the Pa10Master of this process (shared tick, lock-step tests)
//   BusWristSource     passive listeners on the bus (a sensor process of its own): the wrist
//                      sensor's TPDOs through rtm::can::SensorListener and the drives'
//                      broadcast TPDO1s through rtm::can::JointListener
#pragma once

#include "arm/can/joint_listener.h"
#include "arm/can/master.h"
#include "arm/can/sensor_listener.h"

#include <array>
#include <cstdint>
#include <string>
#include <string_view>

namespace rtm::comp {

// One wrist reading with the arm configuration it was taken in.
struct WristSample {
  std::array<double, 6> wrench_sensor{};  // Fx Fy Fz [N], Tx Ty Tz [N·m], sensor (flange) frame
  std::array<double, 7> q_rad{};          // joint positions s1..w2 [rad]
  std::uint64_t sequence = 0;             // grows by one or more with each new wrench
  bool valid = false;                     // a wrench and a full joint vector were seen
};

// Why a source cannot deliver: the arm library's one fault vocabulary (arm/can/fault.h), as
// the force sensor's node gives it. heartbeat_lost: the node has been silent longer than its
// timeout (a pulled cable, a node that reboots); it clears by itself when the node is heard
// again, and the component waits for it, within a budget. emergency: the sensor reports a fault
// of its own (EMCY with a non-zero code), its readings cannot be trusted until someone looks at
// it. bus_error: a bus failed, or anything else the source cannot recover from.
using rtm::can::Fault;
using rtm::can::FaultKind;

// The hardware seam of the Sensor component.
class WristSampleSource {
 public:
  virtual ~WristSampleSource() = default;
  // The latest sample; never blocks, allocates nothing.
  virtual WristSample latest() const = 0;
  // The kind of fault now; never blocks for long, allocates nothing (asked each cycle in
  // which no new sample came).
  virtual FaultKind fault_kind() const = 0;
  // The fault now with its text (may allocate: asked when the kind changes, not each cycle).
  // Its kind may differ from an earlier fault_kind() when the fault changed in between.
  virtual Fault fault() const = 0;
};

// Reads the master of this process. The master must outlive the source. Only the master's
// faults that concern the wrist sensor node are the source's (a heartbeat loss, an EMCY of
// the sensor); the others are the actuator's. The master latches them until its fault reset
// (the actuator's on() after reset()), so in this mode a heartbeat loss clears only then.
// fault_kind() allocates while the master holds a fault (the master hands out its reason as a
// string), never while it holds none.
class MasterWristSource final : public WristSampleSource {
 public:
  explicit MasterWristSource(const rtm::can::Pa10Master& master) : master_(master) {}
  WristSample latest() const override;
  FaultKind fault_kind() const override { return fault().kind; }
  Fault fault() const override;

 private:
  const rtm::can::Pa10Master& master_;
};

// The sensor's own process: listens on sensor_bus_spec (the wrist sensor) and drive_bus_spec
// (the drives). A wrist node heard once and then silent for longer than heartbeat_timeout_ns
// is a heartbeat loss. Throws rtm::can::BusError naming the spec when a bus cannot be opened.
class BusWristSource final : public WristSampleSource {
 public:
  static constexpr std::int64_t kDefaultHeartbeatTimeout_ns = 300'000'000;  // 3 heartbeats of 100 ms

  BusWristSource(std::string_view drive_bus_spec, std::string_view sensor_bus_spec,
                 std::int64_t heartbeat_timeout_ns = kDefaultHeartbeatTimeout_ns);
  WristSample latest() const override;
  FaultKind fault_kind() const override;
  Fault fault() const override;

 private:
  rtm::can::SensorListener wrench_;
  rtm::can::JointListener joints_;
};

}  // namespace rtm::comp
