// SPDX-License-Identifier: Apache-2.0
#include "components/controller/controller.h"

#include "host/runner.h"
#include "rtm/data.h"
#include "rtm/log.h"

#include <fmt/format.h>
#include <spdlog/logger.h>

#include <cmath>
#include <stdexcept>

namespace rtm::comp {

void ControllerParams::add_options(CLI::App& app) {
  rtm::add_array_option(app, "--gain", gain, "6 gains: x y z in (m/s)/N, rx ry rz in (rad/s)/(N·m)");
  rtm::add_array_option(app, "--free-gain", free_gain,
                        "6 gains used in free space while --approach-speed is on, units as --gain");
  app.add_option("--approach-speed", approach_speed_m_s,
                 "free-space speed limit [m/s] so the tool meets a surface at most this fast; 0: the paper's "
                 "plain P (--gain everywhere)")
      ->capture_default_str();
  app.add_option("--contact-force", contact_force_N,
                 "|force| [N] from which the tool is in contact (left after 10 cycles below half of it)")
      ->capture_default_str();
  app.add_option("--stale-periods", stale_periods,
                 "cycles without a new input datum before the command is withheld (the actuator brakes)")
      ->capture_default_str();
}

void ControllerParams::validate() const {
  for (std::size_t i = 0; i < gain.size(); ++i) {
    if (!std::isfinite(gain[i]))
      throw std::invalid_argument(fmt::format("controller gain[{}] = {} is not a finite number", i, gain[i]));
  }
  for (std::size_t i = 0; i < free_gain.size(); ++i) {
    if (!std::isfinite(free_gain[i]))
      throw std::invalid_argument(fmt::format("controller free_gain[{}] = {} is not a finite number", i, free_gain[i]));
  }
  if (!(std::isfinite(approach_speed_m_s) && approach_speed_m_s >= 0))
    throw std::invalid_argument(fmt::format("controller approach_speed = {} m/s must be 0 (off) or more",
                                            approach_speed_m_s));
  if (!(std::isfinite(contact_force_N) && contact_force_N > 0))
    throw std::invalid_argument(fmt::format("controller contact_force = {} N must be above 0", contact_force_N));
  if (stale_periods == 0) throw std::invalid_argument("controller stale_periods must be at least 1");
}

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
  add_parameter(rtm::live_numbers("gain", "(m/s)/N, (rad/s)/(N·m)", "6 gains: x y z, then rx ry rz (in contact)",
                                  gain_live_));
  add_parameter(rtm::live_numbers("free_gain", "(m/s)/N, (rad/s)/(N·m)",
                                  "6 gains in free space while approach_speed is on", free_gain_live_));
  add_parameter(rtm::live_numbers("approach_speed", "m/s", "free-space speed limit; 0: the paper's P everywhere",
                                  approach_speed_live_, [](const std::vector<double>& v) {
                                    if (v[0] < 0) throw std::invalid_argument("approach_speed must be 0 (off) or more");
                                  }));
  add_parameter(rtm::live_numbers("contact_force", "N", "|force| from which the tool is in contact",
                                  contact_force_live_, [](const std::vector<double>& v) {
                                    if (!(v[0] > 0)) throw std::invalid_argument("contact_force must be above 0");
                                  }));
  add_parameter(rtm::cycles_when_off("stale_periods",
                                     "cycles without a new input datum before the command is withheld (the actuator brakes)",
                                     params_.stale_periods, 1, 1'000'000));
}

ControllerParams Controller::params() const {
  ControllerParams now = params_;
  now.gain = gain_live_.published();
  now.free_gain = free_gain_live_.published();
  now.approach_speed_m_s = approach_speed_live_.published()[0];
  now.contact_force_N = contact_force_live_.published()[0];
  return now;
}

void Controller::on_start() {
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
               params_.stale_periods);
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

void Controller::take_live_parameters() {
  gain_live_.take(cycle_params_.gain);
  free_gain_live_.take(cycle_params_.free_gain);
  std::array<float, 1> one{};
  if (approach_speed_live_.take(one)) cycle_params_.approach_speed_m_s = one[0];
  if (contact_force_live_.take(one)) cycle_params_.contact_force_N = one[0];
}

}  // namespace rtm::comp
