// Sensor: the wrist force/torque sensor as an RT component (paper Fig. 5). Each cycle it takes
// the newest wrench, turns it into the arm's base frame, stamps the time and writes it to
// OutPort 0 ("wrench", alias "out0", RTM::TimedFloat6). Statistic: samples.
//
// Sign and frame (what the controller's gain*(ref + sen) relies on): the value is the wrench
// the outside world exerts on the tool, in the BASE frame (N, N·m, torque about the sensor
// origin). Pressing the tool down on the table therefore reads +Fz (the table pushes up). The
// sim's sensor (sim/pa10_plant.cpp, site wrist_ft) reports exactly that wrench in the sensor
// frame, whose axes are those of the URDF's tool0 (ft_sensor_to_tool0 has no rotation); so
// wrench_base = R_base_tool0(q) * wrench_sensor, with R from the forward kinematics of the
// joint positions heard on the bus.
#pragma once

#include "components/sensor/wrist_source.h"

#include "arm/pa10/kinematics.h"
#include "rtm/component.h"

#include <Eigen/Core>

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

namespace rtm::comp {

// wrench_sensor (Fx Fy Fz Tx Ty Tz, sensor frame) rotated into the base frame, given the
// rotation base <- sensor.
std::array<double, 6> wrench_sensor_to_base(const Eigen::Matrix3d& rotation_base_sensor,
                                            const std::array<double, 6>& wrench_sensor);

class Sensor final : public rtm::Component {
 public:
  // kinematics: the arm model (e.g. Kinematics::pa10()), chain
  // base_link -> tool0.
  Sensor(std::string name, std::unique_ptr<WristSampleSource> source, rtm::pa10::Kinematics kinematics);

  // Writes a datum only for a wrench not written before; a source that reports a fault while
  // no new wrench arrives throws (the component goes to COMPONENT_ERROR with the reason).
  void on_cycle(const rtm::CycleContext& ctx) override;
  void on_start() override;

  rtm::OutPort<RTM::TimedFloat6>& out() { return out_; }
  std::uint64_t samples_written() const { return written_.load(std::memory_order_relaxed); }

 private:
  std::unique_ptr<WristSampleSource> source_;
  rtm::pa10::Kinematics kinematics_;
  rtm::pa10::JointVector q_rad_ = rtm::pa10::JointVector::Zero();
  std::uint64_t last_sequence_ = 0;
  RTM::TimedFloat6 datum_{};
  std::atomic<std::uint64_t> written_{0};
  rtm::OutPort<RTM::TimedFloat6>& out_ = add_out_port<RTM::TimedFloat6>(
      "wrench", {"wrench the world exerts on the tool, base frame",
                 rtm::wrench_elements()});
};

}  // namespace rtm::comp
