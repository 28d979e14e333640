// SPDX-License-Identifier: Apache-2.0
#include "components/actuator/actuator.h"

#include "rtm/data.h"
#include "rtm/log.h"

#include <fmt/format.h>
#include <spdlog/logger.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace rtm::comp {

const rtm::ParameterTable<ActuatorParams>& actuator_parameters() {
  static const rtm::ParameterTable<ActuatorParams> table{"actuator"};
  return table;
}

void ActuatorParams::validate() const { actuator_parameters().validate(*this); }

std::array<float, 6> clamp_twist(const std::array<float, 6>& limit, const RTM::Float6& command) {
  std::array<float, 6> out{};
  for (std::size_t i = 0; i < 6; ++i) out[i] = std::clamp(command[i], -limit[i], limit[i]);
  return out;
}

Actuator::Actuator(std::string name, std::unique_ptr<VelocityArm> arm, ActuatorParams params)
    : Component(std::move(name), "actuator"), arm_(std::move(arm)), params_(params) {
  if (!arm_) throw std::invalid_argument("Actuator " + this->name() + ": no arm");
  params_.validate();
  describe_self();
}

void Actuator::describe_self() {
  set_description("PA10 Cartesian-velocity actuator with limiter and command watchdog");
  add_counters(counters_);
  add_percentile_statistics("latency", "sensor sample to drive command leaving for the bus", latency_);
  add_statistic("latency_samples", "", "commands seen leaving for the bus",
                [this] { return static_cast<double>(latency_.count()); });
  add_statistic("bus_foreign_frames", "", "frames of another master on the arm's bus (a fault once started)",
                [this] { return static_cast<double>(arm_->diagnostics().bus_health().foreign_frames); });
  add_statistic("bus_unsolicited_frames", "", "TPDOs beyond what a node was asked for (spoofed: a fault)",
                [this] { return static_cast<double>(arm_->diagnostics().bus_health().unsolicited_frames); });
  add_statistic("following_velocity_peak", "rad/s", "largest |actual - commanded| joint velocity seen",
                [this] { return arm_->diagnostics().bus_health().peak_velocity_error_rad_s; });
  add_statistic("following_position_peak", "rad", "largest |actual - integrated command| joint position seen",
                [this] { return arm_->diagnostics().bus_health().peak_position_error_rad; });
  add_statistic("bus_target_expiries", "",
                "twists the bus master dropped for not being renewed within its expiry (zero sent)",
                [this] { return static_cast<double>(arm_->diagnostics().bus_health().target_expiries); });
  add_percentile_statistics("handover", "sensor sample to twist handed to the arm", handover_latency_);
  add_parameters(actuator_parameters(), params_live_);
}

void Actuator::retry_sensor_loss(bool faulted) {
  if (faulted) sensor_clear_cycles_ = 0;
  if (!in_sensor_loss_) {
    in_sensor_loss_ = true;
    sensor_loss_cycles_ = 0;
    const std::uint64_t event = counters_.sensor_heartbeat_losses.add();
    log().warn("{}: {}: drives stopped, retrying for up to {} cycles (event {})", name(), arm_->fault().reason,
               params_.sensor_recovery_periods.value(), event);
    command_freshness_.reset();
    command_bad_ = false;
    twist_ = {};
  }
  if (++sensor_loss_cycles_ > params_.sensor_recovery_periods)
    throw std::runtime_error(fmt::format("arm fault: {}: not heard again within {} cycles", arm_->fault().reason,
                                         params_.sensor_recovery_periods.value()));
  if (faulted && sensor_loss_cycles_ % ActuatorParams::kSensorRetryPeriods == 0) {
    counters_.sensor_reset_attempts.add();
    arm_->reset();
  }
}

ActuatorParams Actuator::params() const { return params_live_.published(); }

void Actuator::on_start() {
  if (const rtm::pa10::ArmFault fault = arm_->fault(); rtm::can::latched(fault.kind)) {
    log().info("{}: resetting the arm ({})", name(), fault.reason);
    arm_->reset();
  }
  params_ = params_live_.published();  // watchdog_periods, sensor_recovery_periods: only while off
  // A command that arrived while off is not one to act on.
  RTM::TimedFloat6 discard;
  command_in_.read(discard);
  command_freshness_ = rtm::Freshness(params_.watchdog_periods);
  command_bad_ = false;
  twist_ = {};
  in_sensor_loss_ = false;
}

void Actuator::record_sent_latency() {
  if (pending_sequence_ == 0) return;
  const rtm::pa10::ArmDiagnostics::SentCommand sent = arm_->diagnostics().last_sent();
  if (sent.sequence < pending_sequence_) return;
  latency_.record(sent.sent_realtime_ns - pending_stamp_ns_);
  pending_sequence_ = 0;
}

void Actuator::resume_after(rtm::Counter& events) {
  const std::uint64_t event = events.add();
  log().warn("{}: {}: resetting the drives, moving again on the next command (recovery {})", name(),
             arm_->fault().reason, event);
  arm_->reset();
  command_freshness_.reset();  // never on a command from before
  command_bad_ = false;
  twist_ = {};
}

void Actuator::recover_feedback_gap() {
  const std::uint64_t now = counters_.cycles.value();
  if (feedback_gaps_in_window_ > 0 && now - last_feedback_gap_cycle_ > kFeedbackGapWindowCycles)
    feedback_gaps_in_window_ = 0;
  last_feedback_gap_cycle_ = now;
  if (++feedback_gaps_in_window_ > kMaxFeedbackGaps)
    throw std::runtime_error(fmt::format("arm fault: {} ({} times within {} cycles of each other)",
                                         arm_->fault().reason, feedback_gaps_in_window_, kFeedbackGapWindowCycles));
  resume_after(counters_.feedback_gap_recoveries);
}

// What the arm said of this cycle's order: recover from what is recoverable, throw otherwise.
void Actuator::handle_arm_status(FaultKind status) {
  using rtm::pa10::Recovery;
  // Which faults are recoverable is the arm library's to say; how often, and for how long,
  // the actuator's parameters.
  const std::uint8_t node = status == FaultKind::heartbeat_lost ? arm_->fault().node : 0;  // which node fell silent
  switch (rtm::can::recovery(status, node)) {
    case Recovery::reset:
      // command_loss: the drives faulted only because commands came late. cycle_owner_lost:
      // the master took its cycles back from a shared tick that sent no SYNC for a while (a
      // stall); the drives are held at zero and the tick takes the cycles again.
      resume_after(status == FaultKind::command_loss ? counters_.command_loss_recoveries
                                                     : counters_.cycle_owner_recoveries);
      break;
    case Recovery::reset_a_few: recover_feedback_gap(); break;
    case Recovery::wait_for_node: retry_sensor_loss(true); break;
    case Recovery::stop: throw std::runtime_error("arm fault: " + arm_->fault().reason);
    case Recovery::none:
      if (in_sensor_loss_ && status == FaultKind::not_enabled)
        retry_sensor_loss(false);  // re-enabling after a reset: the node may still be silent
      break;
  }
  // A reset can look good for a cycle before the master's heartbeat check latches the silence
  // again: the node counts as heard once the arm has stayed fault-free for a while.
  if (in_sensor_loss_ && status == FaultKind::none && ++sensor_clear_cycles_ < kSensorClearCycles)
    retry_sensor_loss(false);
  else if (in_sensor_loss_ && status == FaultKind::none) {
    // A fault reset held through the re-enabling: the node is heard again. Move on the next
    // new command only.
    in_sensor_loss_ = false;
    const std::uint64_t event = counters_.sensor_heartbeat_recoveries.add();
    log().warn("{}: the force sensor is heard again after {} cycles: moving on the next command (recovery {})",
               name(), sensor_loss_cycles_, event);
    command_freshness_.reset();
    command_bad_ = false;
    twist_ = {};
  }
}

void Actuator::on_cycle(const rtm::CycleContext&) {
  counters_.cycles.add();
  // The bus master sends on its own cycle: the command of an earlier cycle has left by now.
  record_sent_latency();
  bool fresh_command = false;
  bool watchdog_fired = false;
  const bool new_command = command_in_.read(command_) == rtm::ReadResult::NewData;
  const bool went_stale = command_freshness_.tick(new_command) == rtm::Freshness::Change::went_stale;
  if (new_command) {
    const bool bad = rtm::has_non_finite(command_);
    if (bad) {
      if (!command_bad_) {
        counters_.non_finite_events.add();
        log().warn("{}: command holds NaN/inf: quick stop (event {})", name(), counters_.non_finite_events.value());
      }
      twist_ = {};
    } else {
      params_live_.take(cycle_params_);
      twist_ = clamp_twist(cycle_params_.limit, command_.val);
      for (CORBA::ULong i = 0; i < 6; ++i) {
        if (twist_[i] != command_.val[i]) {
          counters_.clamped.add();
          break;
        }
      }
      counters_.commands.add();
      fresh_command = true;
    }
    command_bad_ = bad;
  } else if (!command_freshness_.seen()) {
    twist_ = {};
  } else if (went_stale) {
    watchdog_fired = true;
    twist_ = {};
    command_in_.expire_last();  // braked: the chain's age stops at the last command acted on
    counters_.watchdog_events.add();
  }
  // Otherwise the last command (or the brake after the watchdog) is repeated.

  // While a silent force sensor is retried the drives stay braked, between resets too.
  const bool brake = in_sensor_loss_ || (command_freshness_.seen() && (!command_freshness_.fresh() || command_bad_));
  // Where the bus is when the arm is told, for the event report (read before, so the brake
  // leaves with the next SYNC after this position at the latest).
  const rtm::pa10::ArmDiagnostics::BusPosition bus =
      fresh_command || watchdog_fired ? arm_->diagnostics().bus_position() : rtm::pa10::ArmDiagnostics::BusPosition{};
  const FaultKind status = brake ? arm_->quick_stop() : arm_->order_velocity(twist_);
  if (fresh_command) last_command_bus_ = bus;
  if (watchdog_fired) {
    log().warn("{}: watchdog: no new command for {} periods since bus cycle {} (SYNC counter {}): quick stop "
               "after bus cycle {} (SYNC counter {}) (event {})",
               name(), params_.watchdog_periods.value(), last_command_bus_.cycle, last_command_bus_.sync_counter, bus.cycle,
               bus.sync_counter, counters_.watchdog_events.value());
  }
  handle_arm_status(status);
  if (status == FaultKind::not_enabled) counters_.not_ready_cycles.add();
  if (fresh_command && status == FaultKind::none) {
    const std::int64_t stamp_ns = rtm::to_ns(command_.tm);
    handover_latency_.record(rtm::to_ns(rtm::now()) - stamp_ns);
    pending_sequence_ = arm_->diagnostics().command_sequence();
    pending_stamp_ns_ = stamp_ns;
  } else if (brake || status != FaultKind::none) {
    pending_sequence_ = 0;  // that command will not leave as such
  }
  const bool moving = status == FaultKind::none && !brake;
  for (std::size_t i = 0; i < 6; ++i) last_twist_[i].store(moving ? twist_[i] : 0.0f, std::memory_order_relaxed);
  // After the command has gone to the arm, so the forward kinematics delay nothing on its way.
  write_pose();
}

void Actuator::write_pose() {
  if (!arm_->measured_tool_pose(measured_pose_)) return;
  for (CORBA::ULong i = 0; i < 6; ++i) pose_.val[i] = static_cast<float>(measured_pose_[i]);
  pose_.tm = rtm::now();  // a measurement of this cycle: no command's stamp
  pose_out_.write(pose_);
}

void Actuator::on_stop() {
  arm_->stop();
  for (auto& v : last_twist_) v.store(0.0f, std::memory_order_relaxed);
  const ActuatorCounters& c = counters_;
  const ActuatorLatency l = latency();
  log().info(
      "{}: off, zero velocity. cycles {}, commands {}, clamped {}, watchdog events {}, non-finite events {}, "
      "command-loss recoveries {}, cycle-owner recoveries {}, feedback-gap recoveries {}, not-ready cycles {}, "
      "sample-to-master handover p50 {} us p99 {} us max {} us, "
      "sample-to-drive latency p50 {} us p99 {} us max {} us ({} commands seen leaving for the bus)",
      name(), c.cycles, c.commands, c.clamped, c.watchdog_events, c.non_finite_events, c.command_loss_recoveries,
      c.cycle_owner_recoveries, c.feedback_gap_recoveries, c.not_ready_cycles, l.handover_p50_ns / 1000,
      l.handover_p99_ns / 1000, l.handover_max_ns / 1000, l.latency_p50_ns / 1000, l.latency_p99_ns / 1000, l.latency_max_ns / 1000, l.latency_samples);
}

ActuatorLatency Actuator::latency() const {
  ActuatorLatency c;
  c.latency_p50_ns = latency_.percentile_ns(0.5);
  c.latency_p99_ns = latency_.percentile_ns(0.99);
  c.latency_max_ns = latency_.max_ns();
  c.latency_samples = latency_.count();
  c.handover_p50_ns = handover_latency_.percentile_ns(0.5);
  c.handover_p99_ns = handover_latency_.percentile_ns(0.99);
  c.handover_max_ns = handover_latency_.max_ns();
  return c;
}

std::array<float, 6> Actuator::last_twist() const {
  std::array<float, 6> out{};
  for (std::size_t i = 0; i < 6; ++i) out[i] = last_twist_[i].load(std::memory_order_relaxed);
  return out;
}

}  // namespace rtm::comp
