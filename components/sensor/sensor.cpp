// SPDX-License-Identifier: Apache-2.0
#include "components/sensor/sensor.h"

#include "rtm/data.h"
#include "rtm/log.h"

#include <Eigen/Geometry>
#include <fmt/format.h>
#include <spdlog/logger.h>

#include <stdexcept>

namespace rtm::comp {

const rtm::ParameterTable<SensorParams>& sensor_parameters() {
  static const rtm::ParameterTable<SensorParams> table{"sensor"};
  return table;
}

void SensorParams::validate() const { sensor_parameters().validate(*this); }

std::array<double, 6> wrench_sensor_to_base(const Eigen::Matrix3d& rotation_base_sensor,
                                            const std::array<double, 6>& wrench_sensor) {
  const Eigen::Vector3d force = rotation_base_sensor * Eigen::Vector3d(wrench_sensor[0], wrench_sensor[1], wrench_sensor[2]);
  const Eigen::Vector3d torque = rotation_base_sensor * Eigen::Vector3d(wrench_sensor[3], wrench_sensor[4], wrench_sensor[5]);
  return {force.x(), force.y(), force.z(), torque.x(), torque.y(), torque.z()};
}

namespace {

bool is_wrist(rtm::can::ForceSensor node) { return node == rtm::can::ForceSensor::wrist; }

// What the node makes of the component (the table in sensor.h).
struct Role {
  const char* kind;
  const char* port;
  const char* port_text;
  const char* description;
};

const Role& role_of(rtm::can::ForceSensor node) {
  static const Role wrist{"sensor", "wrench", "wrench the world exerts on the tool, base frame",
                          "wrist force/torque sensor: the wrench on the tool in the arm's base frame"};
  static const Role joystick{"joystick", "reference", "reference wrench: the operator's force, base frame",
                             "force-sensor joystick: the operator's force is the reference wrench"};
  return is_wrist(node) ? wrist : joystick;
}

}  // namespace

std::unique_ptr<Sensor> Sensor::wrist(std::string name, std::unique_ptr<ForceSource> source,
                                      rtm::pa10::Kinematics kinematics, SensorParams params) {
  return std::make_unique<Sensor>(std::move(name), rtm::can::ForceSensor::wrist, std::move(source),
                                  std::move(kinematics), params);
}

std::unique_ptr<Sensor> Sensor::joystick(std::string name, std::unique_ptr<ForceSource> source, SensorParams params) {
  return std::make_unique<Sensor>(std::move(name), rtm::can::ForceSensor::joystick, std::move(source), std::nullopt,
                                  params);
}

Sensor::Sensor(std::string name, rtm::can::ForceSensor node, std::unique_ptr<ForceSource> source,
               std::optional<rtm::pa10::Kinematics> kinematics, SensorParams params)
    : Component(std::move(name), role_of(node).kind),
      node_(node),
      source_(std::move(source)),
      kinematics_(is_wrist(node) ? std::move(kinematics) : std::nullopt),
      params_(params),
      out_(add_out_port<RTM::TimedFloat6>(role_of(node).port, {role_of(node).port_text, rtm::wrench_elements()})) {
  if (!source_) throw std::invalid_argument("Sensor " + this->name() + ": no force source");
  if (is_wrist(node) && !kinematics_)
    throw std::invalid_argument("Sensor " + this->name() + ": the wrist sensor needs the arm's kinematics");
  params_.validate();
  set_description(role_of(node).description);
  add_counters(counters_);
  add_parameters(sensor_parameters(), params_live_);
}

void Sensor::on_start() {
  // A wrench already seen before on() is not fresh: it would reach the controller as new.
  last_sequence_ = source_->latest().sequence;
  params_ = params_live_.published();  // recovery_timeout_periods changes only while off
  recovery_budget_ = params_.recovery_timeout_periods;
  // A loss still under way is seen again (and counted as a new one) in the first cycle.
  lost_ = false;
  lost_flag_.store(false, std::memory_order_relaxed);
}

void Sensor::write(const ForceSample& sample) {
  last_sequence_ = sample.sequence;
  std::array<double, 6> wrench_base = sample.wrench_sensor;  // the joystick's frame is base-aligned
  if (kinematics_) {
    for (int j = 0; j < rtm::pa10::kJointCount; ++j) q_rad_[j] = sample.q_rad[static_cast<std::size_t>(j)];
    wrench_base = wrench_sensor_to_base(kinematics_->tool_pose(q_rad_).linear(), sample.wrench_sensor);
  }
  for (CORBA::ULong i = 0; i < 6; ++i) datum_.val[i] = static_cast<float>(wrench_base[i]);
  datum_.tm = rtm::now();
  out_.write(datum_);
  counters_.samples.add();
}

namespace {

// "2000 cycles (4000 ms)", or "2000 cycles" when the activity has no period.
std::string cycles_text(std::uint64_t cycles, std::int64_t period_ns) {
  if (period_ns <= 0) return fmt::format("{} cycles", cycles);
  return fmt::format("{} cycles ({} ms)", cycles, static_cast<std::int64_t>(cycles) * period_ns / 1'000'000);
}

}  // namespace

void Sensor::begin_loss(const Fault& fault, std::int64_t period_ns) {
  lost_ = true;
  lost_flag_.store(true, std::memory_order_relaxed);
  lost_cycles_ = 0;
  // Wrenches up to this one may be from before the loss: writing resumes only after it.
  loss_sequence_ = source_->latest().sequence;
  loss_reason_ = fault.reason;
  const std::uint64_t event = counters_.heartbeat_losses.add();
  log().warn("{}: {}: writing nothing until it is back with a new wrench, for at most {} (heartbeat loss {})",
             name(), loss_reason_, cycles_text(recovery_budget_, period_ns), event);
}

void Sensor::give_up(std::int64_t period_ns) const {
  const Fault now = source_->fault();
  const std::string budget = cycles_text(recovery_budget_, period_ns);
  if (now.kind == FaultKind::heartbeat_lost) {
    throw std::runtime_error(
        fmt::format("{}: not back within the recovery budget of {} after the loss", now.reason, budget));
  }
  throw std::runtime_error(fmt::format("{}; heartbeat back, but no wrench newer than the loss within the recovery "
                                       "budget of {}",
                                       loss_reason_, budget));
}

void Sensor::on_cycle(const rtm::CycleContext& ctx) {
  const ForceSample sample = source_->latest();
  if (!lost_) {
    if (fresh(sample)) {
      write(sample);
      return;
    }
    // Only here (rarely, and no allocation when healthy) ask why nothing new came.
    if (source_->fault_kind() == FaultKind::none) return;
    const Fault fault = source_->fault();
    if (fault.kind == FaultKind::none) return;  // cleared in between
    if (fault.kind != FaultKind::heartbeat_lost) throw std::runtime_error(fault.reason);
    begin_loss(fault, ctx.period_ns);
    return;
  }

  // In a heartbeat loss: nothing is written until the node's heartbeat is back and a wrench
  // newer than the loss came.
  ++lost_cycles_;
  const FaultKind kind = source_->fault_kind();
  if (kind != FaultKind::none && kind != FaultKind::heartbeat_lost) {
    const Fault fault = source_->fault();
    if (fault.kind != FaultKind::none && fault.kind != FaultKind::heartbeat_lost)
      throw std::runtime_error(fault.reason);
  }
  if (kind == FaultKind::none && fresh(sample) && sample.sequence > loss_sequence_) {
    lost_ = false;
    lost_flag_.store(false, std::memory_order_relaxed);
    const std::uint64_t event = counters_.heartbeat_recoveries.add();
    log().info("{}: heartbeat and a new wrench back after {} of loss ({}): writing again (recovery {})", name(),
               cycles_text(lost_cycles_, ctx.period_ns), loss_reason_, event);
    write(sample);
    return;
  }
  if (lost_cycles_ >= recovery_budget_) give_up(ctx.period_ns);
}

}  // namespace rtm::comp
