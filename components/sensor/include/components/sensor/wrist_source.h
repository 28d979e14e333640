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

// The hardware seam of the Sensor component.
class WristSampleSource {
 public:
  virtual ~WristSampleSource() = default;
  // The latest sample; never blocks, allocates nothing.
  virtual WristSample latest() const = 0;
  // Why the source cannot deliver ("" when it can). Called only when no new sample came.
  virtual std::string fault() const = 0;
};

// Reads the master of this process. The master must outlive the source.
class MasterWristSource final : public WristSampleSource {
 public:
  explicit MasterWristSource(const rtm::can::Pa10Master& master) : master_(master) {}
  WristSample latest() const override;
  std::string fault() const override { return ""; }  // the actuator owns the master's faults

 private:
  const rtm::can::Pa10Master& master_;
};

// The sensor's own process: listens on sensor_bus_spec (the wrist sensor) and drive_bus_spec
// (the drives). Throws rtm::can::BusError naming the spec when a bus cannot be opened.
class BusWristSource final : public WristSampleSource {
 public:
  BusWristSource(std::string_view drive_bus_spec, std::string_view sensor_bus_spec);
  WristSample latest() const override;
  std::string fault() const override;

 private:
  rtm::can::SensorListener wrench_;
  rtm::can::JointListener joints_;
};

}  // namespace rtm::comp
