// SPDX-License-Identifier: Apache-2.0
// Where the force-sensor component gets its samples: one of the arm's 6-axis F/T nodes (the
// wrist's, 0x10, or the operator's joystick, 0x11), with the joint positions that say how the
// wrist sensor's frame is oriented.
//
// Two sources behind one small seam, so the component never knows which one it reads:
//   MasterForceSource  the Pa10Master of this process (shared tick, lock-step tests)
//   BusForceSource     passive listeners on the bus (a sensor process of its own): the node's
//                      TPDOs through rtm::can::SensorListener and, when asked for, the drives'
//                      broadcast TPDO1s through rtm::can::JointListener
#pragma once

#include "arm/can/joint_listener.h"
#include "arm/can/master.h"
#include "arm/can/sensor_listener.h"

#include <array>
#include <cstdint>
#include <optional>
#include <string_view>

namespace rtm::comp {

// One reading of the node, with the arm configuration it was taken in.
struct ForceSample {
  std::array<double, 6> wrench_sensor{};  // Fx Fy Fz [N], Tx Ty Tz [N·m], the sensor's own frame
  std::array<double, 7> q_rad{};          // joint positions s1..w2 [rad], when q_valid
  std::uint64_t sequence = 0;             // grows by one or more with each new wrench
  bool valid = false;                     // a wrench was seen
  bool q_valid = false;                   // a full joint vector was seen
};

// Why a source cannot deliver: the arm library's one fault vocabulary (arm/can/fault.h), as
// the node gives it. heartbeat_lost: the node has been silent longer than its timeout (a pulled
// cable, a node that reboots); it clears by itself when the node is heard again, and the
// component waits for it, within a budget. emergency: the sensor reports a fault of its own
// (EMCY with a non-zero code), its readings cannot be trusted until someone looks at it.
// bus_error: a bus failed, or anything else the source cannot recover from.
using rtm::can::Fault;
using rtm::can::FaultKind;

// The hardware seam of the force-sensor component.
class ForceSource {
 public:
  virtual ~ForceSource() = default;
  // The latest sample; never blocks, allocates nothing.
  virtual ForceSample latest() const = 0;
  // The kind of fault now; never blocks for long, allocates nothing (asked each cycle in
  // which no new sample came).
  virtual FaultKind fault_kind() const = 0;
  // The fault now with its text (may allocate: asked when the kind changes, not each cycle).
  // Its kind may differ from an earlier fault_kind() when the fault changed in between.
  virtual Fault fault() const = 0;
};

// Reads the master of this process. The master must outlive the source. Only the master's
// faults that concern this node are the source's (a heartbeat loss, an EMCY of the sensor);
// the others are the actuator's. The master latches them until its fault reset (the
// actuator's on() after reset()), so in this mode a heartbeat loss clears only then.
// fault_kind() allocates while the master holds a fault (the master hands out its reason as a
// string), never while it holds none.
class MasterForceSource final : public ForceSource {
 public:
  MasterForceSource(const rtm::can::Pa10Master& master, rtm::can::ForceSensor node) : master_(master), node_(node) {}
  ForceSample latest() const override;
  FaultKind fault_kind() const override { return fault().kind; }
  Fault fault() const override;

 private:
  const rtm::can::Pa10Master& master_;
  rtm::can::ForceSensor node_;
};

// A process of its own: listens for the node on sensor_bus_spec and, when drive_bus_spec is
// not empty, for the drives' joint positions on it. A node heard once and then silent for
// longer than heartbeat_timeout_ns (on clock, which must outlive the source) is a heartbeat
// loss. Throws rtm::can::BusError naming the spec when a bus cannot be opened.
class BusForceSource final : public ForceSource {
 public:
  static constexpr std::int64_t kDefaultHeartbeatTimeout_ns = 300'000'000;  // 3 heartbeats of 100 ms

  BusForceSource(std::string_view sensor_bus_spec, rtm::can::ForceSensor node, std::string_view drive_bus_spec = {},
                 std::int64_t heartbeat_timeout_ns = kDefaultHeartbeatTimeout_ns,
                 const rtm::Clock& clock = rtm::monotonic_clock());
  ForceSample latest() const override;
  FaultKind fault_kind() const override;
  Fault fault() const override;

 private:
  rtm::can::SensorListener wrench_;
  std::optional<rtm::can::JointListener> joints_;
};

}  // namespace rtm::comp
