#include "components/sensor/sensor.h"

#include "rtm/data.h"

#include <Eigen/Geometry>

#include <stdexcept>

namespace rtm::comp {

std::array<double, 6> wrench_sensor_to_base(const Eigen::Matrix3d& rotation_base_sensor,
                                            const std::array<double, 6>& wrench_sensor) {
  const Eigen::Vector3d force = rotation_base_sensor * Eigen::Vector3d(wrench_sensor[0], wrench_sensor[1], wrench_sensor[2]);
  const Eigen::Vector3d torque = rotation_base_sensor * Eigen::Vector3d(wrench_sensor[3], wrench_sensor[4], wrench_sensor[5]);
  return {force.x(), force.y(), force.z(), torque.x(), torque.y(), torque.z()};
}

Sensor::Sensor(std::string name, std::unique_ptr<WristSampleSource> source, rtm::pa10::Kinematics kinematics)
    : Component(std::move(name), "sensor"), source_(std::move(source)), kinematics_(std::move(kinematics)) {
  if (!source_) throw std::invalid_argument("Sensor " + this->name() + ": no wrist sample source");
  set_description("wrist force/torque sensor: the wrench on the tool in the arm's base frame");
  add_statistic("samples", "", "wrenches written",
                [this] { return static_cast<double>(written_.load(std::memory_order_relaxed)); });
}

void Sensor::on_start() {
  // A wrench already seen before on() is not fresh: it would reach the controller as new.
  last_sequence_ = source_->latest().sequence;
}

void Sensor::on_cycle(const rtm::CycleContext&) {
  const WristSample sample = source_->latest();
  if (!sample.valid || sample.sequence == last_sequence_) {
    // Only here (rarely, and no allocation when healthy) ask why nothing new came.
    const std::string why = source_->fault();
    if (!why.empty()) throw std::runtime_error(why);
    return;
  }
  last_sequence_ = sample.sequence;
  for (int j = 0; j < rtm::pa10::kJointCount; ++j) q_rad_[j] = sample.q_rad[static_cast<std::size_t>(j)];
  const Eigen::Isometry3d tool = kinematics_.tool_pose(q_rad_);
  const auto wrench_base = wrench_sensor_to_base(tool.linear(), sample.wrench_sensor);
  for (CORBA::ULong i = 0; i < 6; ++i) datum_.val[i] = static_cast<float>(wrench_base[i]);
  datum_.tm = rtm::now();
  out_.write(datum_);
  written_.fetch_add(1, std::memory_order_relaxed);
}

}  // namespace rtm::comp
