// SPDX-License-Identifier: Apache-2.0
#include "components/joystick/joystick.h"

#include "rtm/data.h"

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
  add_statistic("samples", "", "reference wrenches written",
                [this] { return static_cast<double>(written_.load(std::memory_order_relaxed)); });
}

void Joystick::on_start() { last_sequence_ = source_->latest().sequence; }

void Joystick::on_cycle(const rtm::CycleContext&) {
  const JoystickReading reading = source_->latest();
  if (!reading.valid || reading.sequence == last_sequence_) {
    const std::string why = source_->fault();
    if (!why.empty()) throw std::runtime_error(why);
    return;
  }
  last_sequence_ = reading.sequence;
  for (CORBA::ULong i = 0; i < 6; ++i) datum_.val[i] = static_cast<float>(reading.wrench[i]);
  datum_.tm = rtm::now();
  out_.write(datum_);
  written_.fetch_add(1, std::memory_order_relaxed);
}

}  // namespace rtm::comp
