#include "components/controller/controller.h"

#include "rtm/data.h"
#include "rtm/log.h"
#include "rtm/runner.h"

#include <fmt/format.h>
#include <spdlog/logger.h>

#include <cmath>
#include <stdexcept>

namespace rtm::comp {

void ControllerParams::add_options(CLI::App& app) {
  rtm::add_array_option(app, "--gain", gain, "6 gains: x y z in (m/s)/N, rx ry rz in (rad/s)/(N·m)");
  app.add_option("--stale-periods", stale_periods, "cycles without a new input datum before the command is zero")
      ->capture_default_str();
}

void ControllerParams::validate() const {
  for (std::size_t i = 0; i < gain.size(); ++i) {
    if (!std::isfinite(gain[i]))
      throw std::invalid_argument(fmt::format("controller gain[{}] = {} is not a finite number", i, gain[i]));
  }
  if (stale_periods == 0) throw std::invalid_argument("controller stale_periods must be at least 1");
}

std::array<float, 6> proportional_command(const std::array<float, 6>& gain, const RTM::Float6& reference,
                                          const RTM::Float6& sensor) {
  std::array<float, 6> out{};
  for (std::size_t i = 0; i < 6; ++i) out[i] = gain[i] * (reference[i] + sensor[i]);
  return out;
}

Controller::Controller(std::string name, ControllerParams params)
    : Component(std::move(name), "controller"), params_(params) {
  params_.validate();
  describe_self();
}

void Controller::describe_self() {
  set_description("proportional force controller: twist = gain*(reference + wrench)");
  add_counter("cycles", "cycles run", cycles_);
  add_counter("commands", "proportional commands written", commands_);
  add_counter("withheld_commands", "cycles without a command (stale, missing or bad input): the actuator brakes",
              withheld_commands_);
  add_counter("stale_events", "an input went stale after having been fresh", stale_events_);
  add_counter("non_finite_events", "an input started holding NaN/inf", non_finite_events_);
  add_parameter(rtm::live_numbers("gain", "(m/s)/N, (rad/s)/(N·m)", "6 gains: x y z, then rx ry rz", gain_live_));
  add_parameter(rtm::cycles_when_off("stale_periods", "cycles without a new input datum before the command is zero",
                                     params_.stale_periods, 1, 1'000'000));
}

ControllerParams Controller::params() const {
  ControllerParams now = params_;
  now.gain = gain_live_.published();
  return now;
}

void Controller::on_start() {
  // Data that arrived while off is not fresh: a restart begins stale until new data comes.
  sensor_ = Input{params_.stale_periods};
  reference_ = Input{params_.stale_periods};
  RTM::TimedFloat6 discard;
  sensor_in_.read(discard);
  reference_in_.read(discard);
}

rtm::Freshness::Change Controller::update(rtm::InPort<RTM::TimedFloat6>& port, Input& input) {
  return input.freshness.tick(port.read(input.datum) == rtm::ReadResult::NewData);
}

// Fresh and finite; counts and logs (once per event) an input going stale or bad.
bool Controller::usable(Input& input, rtm::Freshness::Change change, const char* what) {
  if (change == rtm::Freshness::Change::went_stale) {
    stale_events_.fetch_add(1, std::memory_order_relaxed);
    log().warn("{}: {} input stale (no new datum for {} periods): command withheld, the actuator brakes", name(), what,
               params_.stale_periods);
  }
  if (!input.freshness.fresh()) return false;
  const bool bad = rtm::has_non_finite(input.datum);
  if (bad && !input.was_bad) {
    non_finite_events_.fetch_add(1, std::memory_order_relaxed);
    log().warn("{}: {} input holds NaN/inf: command withheld, the actuator brakes", name(), what);
  }
  input.was_bad = bad;
  return !bad;
}

void Controller::on_cycle(const rtm::CycleContext&) {
  cycles_.fetch_add(1, std::memory_order_relaxed);
  const auto sensor_change = update(sensor_in_, sensor_);
  const auto reference_change = update(reference_in_, reference_);
  const bool sensor_ok = usable(sensor_, sensor_change, "sensor (wrench)");
  const bool reference_ok = usable(reference_, reference_change, "reference");
  gain_live_.take(gain_);
  if (!(sensor_ok && reference_ok)) {
    // No command at all, not a zero one: the actuator's watchdog then brakes the drives (quick
    // stop), as fast as when the controller itself is lost; a zero command would let them
    // coast down through their velocity loops.
    withheld_commands_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  const auto out = proportional_command(gain_, reference_.datum.val, sensor_.datum.val);
  for (CORBA::ULong i = 0; i < 6; ++i) command_.val[i] = out[i];
  command_.tm = sensor_.datum.tm;
  commands_.fetch_add(1, std::memory_order_relaxed);
  command_out_.write(command_);
}

ControllerCounters Controller::counters() const {
  return {cycles_.load(), commands_.load(), withheld_commands_.load(), stale_events_.load(), non_finite_events_.load()};
}

}  // namespace rtm::comp
