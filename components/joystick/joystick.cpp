// SPDX-License-Identifier: Apache-2.0
#include "components/joystick/joystick.h"

#include "rtm/data.h"
#include "rtm/log.h"

#include <fmt/format.h>
#include <spdlog/logger.h>

#include <stdexcept>

namespace rtm::comp {

namespace pc = rtm::can;

JoystickReading MasterJoystickSource::latest() const {
  const pc::Wrench wrench = master_.wrench(pc::ForceSensor::joystick);
  return {wrench.values, wrench.sequence, wrench.valid};
}

BusJoystickSource::BusJoystickSource(std::string_view bus_spec) : listener_(bus_spec, pc::ForceSensor::joystick) {
  listener_.start();
}

JoystickReading BusJoystickSource::latest() const {
  const pc::Wrench wrench = listener_.latest();
  return {wrench.values, wrench.sequence, wrench.valid};
}

Joystick::Joystick(std::string name, std::unique_ptr<JoystickSource> source)
    : Component(std::move(name), "joystick"), source_(std::move(source)) {
  if (!source_) throw std::invalid_argument("Joystick " + this->name() + ": no joystick source");
  set_description("force-sensor joystick: the operator's force is the reference wrench");
  add_counters(counters_);
}

void Joystick::on_start() {
  last_sequence_ = source_->latest().sequence;
  lost_ = false;  // a loss still under way is seen again, and counted anew, in the first cycle
}

void Joystick::check_fault(const JoystickReading& reading) {
  if (source_->fault_kind() == rtm::can::FaultKind::none) return;
  const rtm::can::Fault fault = source_->fault();
  if (!fault.active()) return;  // cleared in between
  if (fault.kind != rtm::can::FaultKind::heartbeat_lost) throw std::runtime_error(fault.reason);
  lost_ = true;
  lost_cycles_ = 0;
  loss_sequence_ = reading.sequence;  // wrenches up to this one may be from before the loss
  const std::uint64_t event = counters_.heartbeat_losses.add();
  log().warn("{}: {}: writing nothing until it is heard again with a new wrench, for at most {} cycles "
             "(heartbeat loss {})",
             name(), fault.reason, kHeartbeatRecoveryPeriods, event);
}

bool Joystick::back_from_loss(const JoystickReading& reading, bool fresh) {
  const rtm::can::FaultKind kind = source_->fault_kind();
  if (fresh && reading.sequence > loss_sequence_ && kind != rtm::can::FaultKind::heartbeat_lost) {
    lost_ = false;
    const std::uint64_t event = counters_.heartbeat_recoveries.add();
    log().info("{}: the joystick node is heard again after {} cycles: writing again (recovery {})", name(),
               lost_cycles_, event);
    return true;
  }
  if (++lost_cycles_ < kHeartbeatRecoveryPeriods) {
    if (kind != rtm::can::FaultKind::none && kind != rtm::can::FaultKind::heartbeat_lost) {
      const rtm::can::Fault fault = source_->fault();  // another fault meanwhile: no stall
      if (fault.active() && fault.kind != rtm::can::FaultKind::heartbeat_lost) throw std::runtime_error(fault.reason);
    }
    return false;
  }
  throw std::runtime_error(fmt::format("{}: joystick node not heard again with a new wrench within {} cycles",
                                       name(), kHeartbeatRecoveryPeriods));
}

void Joystick::on_cycle(const rtm::CycleContext&) {
  const JoystickReading reading = source_->latest();
  const bool fresh = reading.valid && reading.sequence != last_sequence_;
  if (lost_ && !back_from_loss(reading, fresh)) return;
  if (!fresh) {
    check_fault(reading);
    return;
  }
  last_sequence_ = reading.sequence;
  for (CORBA::ULong i = 0; i < 6; ++i) datum_.val[i] = static_cast<float>(reading.wrench[i]);
  datum_.tm = rtm::now();
  out_.write(datum_);
  counters_.samples.add();
}

}  // namespace rtm::comp
