// SPDX-License-Identifier: Apache-2.0
#include "arm/pa10/velocity_arm.h"

#include <CLI/CLI.hpp>

#include <chrono>
#include <cmath>
#include <string>
#include <thread>

#include "rt/clock.h"

namespace rtm::pa10 {

namespace {

// CLI::Range lets a NaN through (every comparison with it is false).
const CLI::Validator kFinite(
    [](std::string& text) {
      const double v = std::stod(text);
      return std::isfinite(v) ? std::string() : "'" + text + "' is not a finite number";
    },
    "FINITE");

}  // namespace

void ArmHardware::Options::add_options(CLI::App& app) {
  BusOptions::add_options(app);
  app.add_option("--urdf", urdf, "arm model URDF for the velocity IK (default: the built-in PA10 model)");
  app.add_option("--following-velocity-window", following_velocity_window_rad_s,
                 "rad/s a drive's velocity may differ from its command (0: off)")
      ->check(kFinite)
      ->check(CLI::Range(0.0, 10.0))
      ->capture_default_str();
  app.add_option("--following-position-window", following_position_window_rad,
                 "rad a drive's position may differ from the integral of its commands (0: off)")
      ->check(kFinite)
      ->check(CLI::Range(0.0, 3.2))
      ->capture_default_str();
  app.add_option("--following-position-periods", following_position_periods,
                 "SYNCs over which the position window compares motion with the commands")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  app.add_option("--missed-feedback-limit", missed_feedback_limit,
                 "SYNCs in a row a drive may leave unanswered before the drives are stopped (windows that "
                 "closed late, a stall of this process or the host, do not count)")
      ->check(CLI::Range(1, 10'000))
      ->capture_default_str();
  app.add_option("--following-periods", following_error_periods,
                 "SYNCs in a row outside a window before the drives are stopped")
      ->check(CLI::Range(1, 500))
      ->capture_default_str();
}

namespace pc = rtm::can;

ArmHardware::ArmHardware(const Options& options) : VelocityArm(diagnostics_), options_(options) {
  pc::MasterConfig config;
  config.period_ns = options.period_ns;
  config.realtime_priority = options.rt_priority;
  config.cpu = options.cpu;
  config.first_deadline_ns = options.master_first_deadline_ns;
  config.step_timeout_ns = options.step_timeout_ns;
  config.following_velocity_window_rad_s = options.following_velocity_window_rad_s;
  config.following_position_window_rad = options.following_position_window_rad;
  config.following_position_periods = options.following_position_periods;
  config.following_error_periods = options.following_error_periods;
  config.missed_feedback_limit = options.missed_feedback_limit;
  master_ = std::make_unique<pc::Pa10Master>(options.bus, options.sensor_bus, config);
  master_->start();
  ArmOptions arm_options;
  arm_options.period_s = static_cast<double>(options.period_ns) * 1e-9;
  arm_ = std::make_unique<Pa10Arm>(options.urdf, *master_, arm_options);
  if (options.run_master_thread) master_->run_periodic();
}

ArmHardware::~ArmHardware() {
  arm_->stop();
  master_->stop();
  arm_.reset();
  master_.reset();  // one last zero-velocity cycle, then NMT pre-operational
}

ArmFault ArmHardware::fault() const {
  // While the component is off nobody orders velocities, so the arm has not looked at the
  // master since: a fault the master latched meanwhile is found here.
  const FaultKind kind = arm_->check_faults();
  if (!rtm::can::latched(kind)) return {kind, 0, 0, arm_->fault_reason()};
  const rtm::can::Fault master = master_->fault();
  return {kind, master.node, master.code, arm_->fault_reason()};
}

bool ArmHardware::measured_tool_pose(std::array<double, 6>& pose) {
  Eigen::Isometry3d tool;
  if (!arm_->measured_tool_pose(tool)) return false;
  pose = pose_vector(tool);
  return true;
}

ArmDiagnostics::BusPosition ArmHardware::Diagnostics::bus_position() const {
  const pc::JointState state = arm_.master_->joint_state();
  return {state.cycle, state.sync_counter};
}

std::uint64_t ArmHardware::Diagnostics::command_sequence() const { return arm_.master_->target_sequence(); }

ArmDiagnostics::BusHealth ArmHardware::Diagnostics::bus_health() const {
  const pc::MasterCounters c = arm_.master_->counters();
  return {c.foreign_frames, c.unsolicited_frames, c.peak_velocity_error_rad_s, c.peak_position_error_rad,
          c.target_expiries};
}

ArmDiagnostics::SentCommand ArmHardware::Diagnostics::last_sent() const {
  const pc::Pa10Master::SentTarget sent = arm_.master_->last_sent();
  return {sent.sequence, sent.sent_realtime_ns};
}

void ArmHardware::stop() {
  arm_->stop();
  // Lock-step: the next step() sends it; cycles taken over (a shared tick runs them): the
  // next transmit_cycle() or the master's thread, once they are handed back.
  if (!master_->running() || master_->cycles_taken_over()) return;
  // Wait until two SYNC cycles have passed: the zero targets were in the RPDOs of the second.
  const std::uint64_t start = master_->counters().cycles;
  const std::int64_t deadline_ns = rtm::monotonic_ns() + 20 * options_.period_ns + 50'000'000;
  while (master_->counters().cycles < start + 2 && rtm::monotonic_ns() < deadline_ns)
    std::this_thread::sleep_for(std::chrono::nanoseconds(options_.period_ns / 4));
}

}  // namespace rtm::pa10
