// SPDX-License-Identifier: Apache-2.0
#include "components/controller/controller.h"

#include "rtm/data.h"
#include "rtm/log.h"

#include <fmt/format.h>
#include <spdlog/logger.h>

#include <cmath>
#include <stdexcept>

namespace rtm::comp {

const rtm::ParameterTable<ControllerParams>& controller_parameters() {
  static const rtm::ParameterTable<ControllerParams> table{"controller"};
  return table;
}

void ControllerParams::validate() const { controller_parameters().validate(*this); }

std::array<float, 6> proportional_command(const std::array<float, 6>& gain, const RTM::Float6& reference,
                                          const RTM::Float6& sensor) {
  std::array<float, 6> out{};
  for (std::size_t i = 0; i < 6; ++i) out[i] = gain[i] * (reference[i] + sensor[i]);
  return out;
}

bool ContactDetector::update(const RTM::Float6& sensor, float contact_force_N) {
  const float force_N = std::sqrt(sensor[0] * sensor[0] + sensor[1] * sensor[1] + sensor[2] * sensor[2]);
  if (!contact_) {
    contact_ = force_N >= contact_force_N;
    cycles_below_ = 0;
  } else if (force_N >= 0.5f * contact_force_N) {
    cycles_below_ = 0;
  } else if (++cycles_below_ >= kLiftOffCycles) {
    contact_ = false;
    cycles_below_ = 0;
  }
  return contact_;
}

GuardedCommand guarded_command(const ControllerParams& params, bool contact, const RTM::Float6& reference,
                               const RTM::Float6& sensor) {
  if (params.approach_speed_m_s <= 0 || contact) return {proportional_command(params.gain, reference, sensor), false};
  GuardedCommand out{proportional_command(params.free_gain, reference, sensor), false};
  auto& v = out.twist;
  const float speed = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  if (speed > params.approach_speed_m_s) {
    const float scale = params.approach_speed_m_s / speed;
    for (std::size_t i = 0; i < 3; ++i) v[i] *= scale;
    out.slowed = true;
  }
  return out;
}

Controller::Controller(std::string name, ControllerParams params)
    : Component(std::move(name), "controller"), params_(params) {
  params_.validate();
  describe_self();
}

void Controller::describe_self() {
  set_description(
      "proportional force controller: twist = gain*(reference + wrench); in free space free_gain, at most "
      "approach_speed (0: the paper's P everywhere)");
  add_counters(counters_);
  add_parameters(controller_parameters(), params_live_);
}

ControllerParams Controller::params() const { return params_live_.published(); }

void Controller::on_start() {
  params_ = params_live_.published();  // stale_periods, which changes only while off
  // Data that arrived while off is not fresh: a restart begins stale until new data comes.
  sensor_ = Input{params_.stale_periods};
  reference_ = Input{params_.stale_periods};
  RTM::TimedFloat6 discard;
  sensor_in_.read(discard);
  reference_in_.read(discard);
  contact_ = ContactDetector{};
}

rtm::Freshness::Change Controller::update(rtm::InPort<RTM::TimedFloat6>& port, Input& input) {
  return input.freshness.tick(port.read(input.datum) == rtm::ReadResult::NewData);
}

// Fresh and finite; counts and logs (once per event) an input going stale or bad.
bool Controller::usable(Input& input, rtm::Freshness::Change change, const char* what) {
  if (change == rtm::Freshness::Change::went_stale) {
    counters_.stale_events.add();
    log().warn("{}: {} input stale (no new datum for {} periods): command withheld, the actuator brakes", name(), what,
               params_.stale_periods.value());
  }
  if (!input.freshness.fresh()) return false;
  const bool bad = rtm::has_non_finite(input.datum);
  if (bad && !input.was_bad) {
    counters_.non_finite_events.add();
    log().warn("{}: {} input holds NaN/inf: command withheld, the actuator brakes", name(), what);
  }
  input.was_bad = bad;
  return !bad;
}

void Controller::on_cycle(const rtm::CycleContext&) {
  counters_.cycles.add();
  const auto sensor_change = update(sensor_in_, sensor_);
  const auto reference_change = update(reference_in_, reference_);
  const bool sensor_ok = usable(sensor_, sensor_change, "sensor (wrench)");
  const bool reference_ok = usable(reference_, reference_change, "reference");
  take_live_parameters();
  if (!(sensor_ok && reference_ok)) {
    // No command at all, not a zero one: the actuator's watchdog then brakes the drives (quick
    // stop), as fast as when the controller itself is lost; a zero command would let them
    // coast down through their velocity loops.
    counters_.withheld_commands.add();
    return;
  }
  const bool was_in_contact = contact_.in_contact();
  const bool contact = contact_.update(sensor_.datum.val, cycle_params_.contact_force_N);
  if (contact != was_in_contact) (contact ? counters_.touch_downs : counters_.lift_offs).add();
  const auto [out, slowed] = guarded_command(cycle_params_, contact, reference_.datum.val, sensor_.datum.val);
  if (slowed) counters_.approach_limited.add();
  for (CORBA::ULong i = 0; i < 6; ++i) command_.val[i] = out[i];
  command_.tm = sensor_.datum.tm;
  counters_.commands.add();
  command_out_.write(command_);
}

void Controller::take_live_parameters() { params_live_.take(cycle_params_); }

}  // namespace rtm::comp
