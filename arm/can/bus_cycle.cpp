// SPDX-License-Identifier: Apache-2.0
#include "arm/can/bus_cycle.h"

#include <cmath>
#include <cstdio>

namespace rtm::can {

namespace {

std::array<bool, 128> expected_nodes(const MasterConfig& config) {
  std::array<bool, 128> expected{};
  for (int j = 0; j < kDriveCount; ++j) expected[drive_node(j)] = true;
  for (ForceSensor s : config.sensors)
    expected[sensor_node(s)] = true;
  return expected;
}

}  // namespace

BusCycle::BusCycle(std::unique_ptr<Bus> drive_bus, std::unique_ptr<Bus> sensor_bus, MasterConfig config)
    : drive_bus_(std::move(drive_bus)),
      separate_sensor_bus_(std::move(sensor_bus)),
      config_(std::move(config)),
      supervisor_(config_, expected_nodes(config_)),
      following_(config_) {
  if (!drive_bus_) throw std::invalid_argument("Pa10Master: no drive bus");
  if (config_.period_ns <= 0) throw std::invalid_argument("Pa10Master: period must be > 0");
  if (config_.missed_feedback_limit < 1 || config_.missed_feedback_limit > 10'000)
    throw std::invalid_argument("Pa10Master: missed_feedback_limit must be 1..10000");
  if (config_.answer_expiry_periods < 1 || config_.answer_expiry_periods > AnswerLedger::kMaxExpiry)
    throw std::invalid_argument("Pa10Master: answer_expiry_periods must be 1..256");
  const auto window_ok = [](double w) { return std::isfinite(w) && w >= 0; };
  if (!window_ok(config_.following_velocity_window_rad_s) || !window_ok(config_.following_position_window_rad) ||
      config_.following_error_periods < 1 || config_.following_position_periods < 1 ||
      config_.following_position_periods > FollowingErrorCheck::kMaxPositionPeriods)
    throw std::invalid_argument(
        "Pa10Master: following-error windows must be finite and >= 0, following_error_periods >= 1, "
        "following_position_periods 1..1000");
  // Our own SYNC on a second socket of the same bus would read as another master's.
  if (separate_sensor_bus_ && separate_sensor_bus_->name() == drive_bus_->name())
    throw std::invalid_argument("Pa10Master: the sensor bus " + drive_bus_->name() +
                                " is the drive bus; give it once (no separate sensor bus)");
  sensor_bus_ = separate_sensor_bus_ ? separate_sensor_bus_.get() : drive_bus_.get();
  drive_ledgers_.fill(AnswerLedger(config_.answer_expiry_periods));
  force_ledgers_.fill(AnswerLedger(config_.answer_expiry_periods));
  torque_ledgers_.fill(AnswerLedger(config_.answer_expiry_periods));
}

std::string BusCycle::describe_buses() const {
  return separate_sensor_bus_ ? drive_bus_->name() + " (sensors on " + sensor_bus_->name() + ")" : drive_bus_->name();
}

void BusCycle::fail(const std::string& what) const {
  throw std::runtime_error("PA10 master on " + describe_buses() + ": " + what);
}

// ---- sending -----------------------------------------------------------------------------

void BusCycle::send(Bus& bus, const Result<can_frame>& frame) {
  if (!frame.ok()) return;  // encoders only fail on NaN/ids, excluded before this point
  if (!bus.send(*frame)) ++counters_.send_dropped;
}

void BusCycle::send_nmt_all(NmtCommand command) {
  send(*drive_bus_, encode_nmt(command, kNmtAllNodes));
  if (separate_sensor_bus_) send(*separate_sensor_bus_, encode_nmt(command, kNmtAllNodes));
}

void BusCycle::add(const Result<can_frame>& frame) {
  if (frame.ok() && outgoing_count_ < outgoing_.size()) outgoing_[outgoing_count_++] = *frame;
}

// ---- receiving ---------------------------------------------------------------------------

void BusCycle::handle(const can_frame& frame, std::int64_t now_ns) {
  const Classified c = classify(frame);
  switch (c.type) {
    case FrameType::drive_feedback: {
      const auto fb = decode_drive_feedback(frame);
      if (!fb) { ++counters_.malformed_frames; return; }
      if (!solicited(drive_ledgers_[static_cast<std::size_t>(joint_index_of(fb->drive))], fb->drive, "TPDO1")) return;
      if (!window_open_) { ++counters_.late_frames; return; }
      if (joints_.add(*fb)) ++counters_.late_frames;  // withheld: which is genuine is unknown
      return;
    }
    case FrameType::sensor_force:
    case FrameType::sensor_torque: handle_sensor(frame, c); return;
    case FrameType::heartbeat: {
      const auto hb = decode_heartbeat(frame);
      if (!hb) { ++counters_.malformed_frames; return; }
      supervisor_.on_heartbeat(hb->node, hb->state, now_ns);
      return;
    }
    case FrameType::emcy: {
      const auto e = decode_emcy(frame);
      if (!e) { ++counters_.malformed_frames; return; }
      ++counters_.emcy_frames;
      supervisor_.on_emcy(e->node, e->error_code);
      return;
    }
    case FrameType::sdo_response: {
      const auto r = decode_sdo_response(frame);
      if (!r) { ++counters_.malformed_frames; return; }
      if (sdo_waiting_node_ != 0 && r->node == sdo_waiting_node_) sdo_response_ = *r;
      return;
    }
    case FrameType::nmt:
    case FrameType::sync:
    case FrameType::drive_command:
    case FrameType::sdo_request: foreign(frame, c); return;
    case FrameType::unknown: ++counters_.unknown_frames; return;
  }
}

// A force or torque frame: one half of a sensor's wrench for the open window.
void BusCycle::handle_sensor(const can_frame& frame, const Classified& c) {
  if (!supervisor_.node_expected(c.node)) return;
  const std::size_t slot = sensor_slot(c.node);
  WrenchAssembly& wrench = wrenches_[slot];
  if (c.type == FrameType::sensor_force) {
    const auto f = decode_sensor_force(frame);
    if (!f) { ++counters_.malformed_frames; return; }
    if (!solicited(force_ledgers_[slot], c.node, "force TPDO1")) { wrench.withhold(); return; }
    if (!window_open_ || wrench.add_force(f->force_N)) ++counters_.late_frames;
  } else {
    const auto t = decode_sensor_torque(frame);
    if (!t) { ++counters_.malformed_frames; return; }
    if (!solicited(torque_ledgers_[slot], c.node, "torque TPDO2")) { wrench.withhold(); return; }
    if (!window_open_ || wrench.add_torque(t->torque_Nm)) ++counters_.late_frames;
  }
}

bool BusCycle::solicited(AnswerLedger& ledger, std::uint8_t node, const char* what) {
  if (ledger.on_answer() != AnswerLedger::Match::unsolicited) return true;
  ++counters_.unsolicited_frames;
  if (supervisor_.started() && !supervisor_.faulted()) {
    supervisor_.latch(FaultKind::spoofed_frame, node, 0,
                      "%s: a %s nobody asked for (more answers than SYNCs): another sender uses its id",
                      node_description(node).c_str(), what);
  }
  return false;
}

void BusCycle::foreign(const can_frame& frame, const Classified& c) {
  ++counters_.foreign_frames;
  if (!supervisor_.started() || supervisor_.faulted()) return;
  char what[96];
  switch (c.type) {
    case FrameType::sync: std::snprintf(what, sizeof what, "a SYNC"); break;
    case FrameType::drive_command:
      std::snprintf(what, sizeof what, "an RPDO to %s", node_description(c.node).c_str());
      break;
    case FrameType::nmt: {
      const auto nmt = decode_nmt(frame);
      if (nmt) std::snprintf(what, sizeof what, "NMT command 0x%02x to node %u", static_cast<unsigned>(nmt->command), nmt->node);
      else std::snprintf(what, sizeof what, "an NMT frame");
      break;
    }
    case FrameType::sdo_request: {
      // Reading an object (a diagnostic tool) is counted; writing one to our nodes is not allowed.
      const auto r = decode_sdo_request(frame);
      if (!r || r->kind != SdoRequestKind::download || !supervisor_.node_expected(r->node)) return;
      std::snprintf(what, sizeof what, "an SDO write of 0x%04x:%02x to %s", r->index, r->subindex,
                    node_description(r->node).c_str());
      break;
    }
    default: return;
  }
  supervisor_.latch(FaultKind::foreign_master, c.node, static_cast<std::uint16_t>(frame.can_id),
                    "%s on the bus that this master did not send: another master (id 0x%03x)", what,
                    static_cast<unsigned>(frame.can_id & CAN_SFF_MASK));
}

// Reads everything already queued on both buses without waiting.
void BusCycle::drain() {
  can_frame frame{};
  const std::int64_t now_ns = monotonic_ns();
  while (drive_bus_->receive(frame, 0)) handle(frame, now_ns);
  if (separate_sensor_bus_)
    while (separate_sensor_bus_->receive(frame, 0)) handle(frame, now_ns);
}

bool BusCycle::wait_readable(std::int64_t deadline_ns) {
  const std::int64_t now_ns = monotonic_ns();
  if (now_ns >= deadline_ns) return false;
  pollfd fds[2] = {{drive_bus_->pollable_fd(), POLLIN, 0}, {-1, POLLIN, 0}};
  if (separate_sensor_bus_) fds[1].fd = separate_sensor_bus_->pollable_fd();
  const timespec left = to_timespec(deadline_ns - now_ns);
  ppoll(fds, separate_sensor_bus_ ? 2 : 1, &left, nullptr);
  return true;
}

bool BusCycle::window_complete() const {
  if (!joints_.complete()) return false;
  for (std::size_t s = 0; s < kSensorCount; ++s)
    if (sensor_enabled(s) && !wrenches_[s].answered()) return false;
  return true;
}

// ---- the cycle ---------------------------------------------------------------------------

void BusCycle::take_requests(std::int64_t now_ns) {
  std::lock_guard lock(mailbox_.mutex_);
  CycleRequests& r = mailbox_.requests_;
  if (r.fault_reset) {
    r.fault_reset = false;
    supervisor_.take_fault_reset(now_ns);
    mailbox_.report_.fault = supervisor_.fault();
    r.target_valid = false;
  }
  supervisor_.take_quick_stop(r.quick_stop, now_ns);
  expire_stale_target(r);
  if (supervisor_.may_move() && r.target_valid) {
    command_rad_s_ = r.target_rad_s;
    command_sequence_ = r.target_sequence;
  } else {
    command_rad_s_.fill(0.0);
    command_sequence_ = 0;
  }
}

// A target that was not renewed for target_expiry_periods cycles is dropped (zero from now on).
void BusCycle::expire_stale_target(CycleRequests& r) {
  const int limit = config_.target_expiry_periods;
  if (r.target_sequence != last_target_sequence_) {
    last_target_sequence_ = r.target_sequence;
    target_age_cycles_ = 0;
  } else if (r.target_valid && limit > 0 && ++target_age_cycles_ >= limit) {
    r.target_valid = false;
    ++counters_.target_expiries;
  }
}

// Writes the 7 RPDOs and SYNC; opens the window for this SYNC's answers.
void BusCycle::send_cycle(std::int64_t now_ns) {
  if (supervisor_.recovering()) {
    // Nodes that dropped out of operational are started again; harmless for the others.
    send_nmt_all(NmtCommand::start);
    supervisor_.on_nmt_restart(now_ns);
  }
  for (int j = 0; j < kDriveCount; ++j) {
    const auto i = static_cast<std::size_t>(j);
    const std::uint16_t cw = supervisor_.controlword(i, last_statusword_[i]);
    add(encode_drive_command(DriveCommand{drive_node(j), cw, command_rad_s_[i]}));
  }
  acting_rad_s_ = sent_rad_s_;
  sent_rad_s_ = command_rad_s_;
  sync_counter_ = next_sync_counter(sync_counter_);
  add(encode_sync(sync_counter_));
  // The drives latched the quick stop at that SYNC; out of operational they take no RPDO from
  // anyone. Repeated each cycle while the fault holds (another master may start them again).
  if (takes_drives_down(supervisor_.fault().kind))
    for (int j = 0; j < kDriveCount; ++j) add(encode_nmt(NmtCommand::enter_pre_operational, drive_node(j)));
  for (AnswerLedger& ledger : drive_ledgers_) ledger.on_sync();
  for (std::size_t k = 0; k < kSensorCount; ++k) {
    force_ledgers_[k].on_sync();
    torque_ledgers_[k].on_sync();
  }
  // The seven RPDOs and SYNC leave in one write: a node woken by the first frame cannot hold
  // the rest back, and on a real bus they go out back to back.
  sync_time_ns_ = monotonic_ns();
  const std::size_t sent = drive_bus_->send_batch(std::span<const can_frame>(outgoing_.data(), outgoing_count_));
  counters_.send_dropped += outgoing_count_ - sent;
  outgoing_count_ = 0;
  if (command_sequence_ != 0) publish_sent(command_sequence_);
  if (separate_sensor_bus_) send(*separate_sensor_bus_, encode_sync(sync_counter_));
  ++cycle_;
  ++counters_.cycles;
  joints_.restart();
  for (WrenchAssembly& wrench : wrenches_) wrench.restart();
  window_open_ = true;
}

// Closes the window of the last SYNC: the supervisor checks the drives, and what arrived is
// published.
void BusCycle::close_window(std::int64_t now_ns, bool count_silence) {
  window_open_ = false;
  for (std::size_t i = 0; i < kDriveCount; ++i)
    if (joints_.trusted(i)) last_statusword_[i] = joints_.feedback(i).statusword;
  if (!count_silence) ++counters_.stalled_windows;
  const DriveSummary drives = supervisor_.check_drives(joints_.answers(), last_statusword_, now_ns, count_silence);
  check_following();
  publish(drives);
}

// While the master commands the drives: each answer against the command it followed.
void BusCycle::check_following() {
  const bool commanding = supervisor_.started() && supervisor_.may_move();
  for (std::size_t i = 0; i < kDriveCount; ++i) {
    const bool enabled = state_from_statusword(last_statusword_[i]) == DriveState::operation_enabled;
    if (!commanding || !enabled) {
      following_.rearm(i);
      continue;
    }
    if (!joints_.trusted(i)) continue;
    const DriveFeedback& fb = joints_.feedback(i);
    FollowingViolation v;
    if (!following_.check(i, acting_rad_s_[i], fb.position_rad, fb.velocity_rad_s, v)) continue;
    const std::uint8_t node = drive_node(static_cast<int>(i));
    supervisor_.latch(FaultKind::following_error, node, 0,
                      "%s: following error: %s %.3f %s outside the window of %.3f for %d SYNCs",
                      node_description(node).c_str(), v.position ? "position" : "velocity", v.error,
                      v.position ? "rad" : "rad/s", v.window, v.answers);
    following_.rearm_all();
    return;
  }
}

void BusCycle::publish(const DriveSummary& drives) {
  std::lock_guard lock(mailbox_.mutex_);
  CycleReport& report = mailbox_.report_;
  JointState& s = report.state;
  joints_.fill(s);
  s.sync_counter = sync_counter_;
  s.sync_time_ns = sync_time_ns_;
  s.cycle = cycle_;
  for (std::size_t k = 0; k < kSensorCount; ++k) {
    if (!(sensor_enabled(k) && wrenches_[k].complete())) continue;
    Wrench& w = report.wrench[k];
    w.values = wrenches_[k].values();
    w.sync_counter = sync_counter_;
    w.sync_time_ns = s.sync_time_ns;
    ++w.sequence;
    w.valid = true;
  }
  const FaultRecord& fault = supervisor_.fault();
  if (fault.active() && !report.fault.active()) {
    mailbox_.requests_.target_valid = false;  // after a fault the old target must not come back
  }
  report.fault = fault;
  report.enabled = drives.all_enabled && !fault.active() && !supervisor_.enabling();
  report.quick_stopped = drives.all_quick_stopped && mailbox_.requests_.quick_stop;
  report.counters = counters_;
  report.counters.peak_velocity_error_rad_s = following_.peak_velocity_error_rad_s();
  report.counters.peak_position_error_rad = following_.peak_position_error_rad();
}

// Right after the RPDOs of target `sequence` (and the SYNC behind them) were written: the end
// of the sample-to-bus path, stamped with CLOCK_REALTIME as sensor samples are.
void BusCycle::publish_sent(std::uint64_t sequence) {
  const std::int64_t sent_ns = realtime_ns();
  std::lock_guard lock(mailbox_.mutex_);
  mailbox_.report_.last_sent = SentTarget{sequence, sent_ns};
}

void BusCycle::bus_failure(const std::exception& error) {
  supervisor_.latch(FaultKind::bus_error, 0, 0, "%s", error.what());
  publish(DriveSummary{false, false});
}

void BusCycle::receive(std::int64_t now_ns) {
  drain();
  // A window much longer than a period means this cycle ran late: our process or the whole
  // host stalled, and the nodes (the simulator among them) may have stalled with it. A drive
  // that did not answer then is not counted as silent; the heartbeat still catches a dead one.
  const bool on_time = now_ns - sync_time_ns_ <= config_.period_ns + config_.period_ns / 2;
  if (cycle_ > 0) close_window(now_ns, on_time);
  supervisor_.check_heartbeats(now_ns);
}

void BusCycle::transmit(std::int64_t now_ns) {
  take_requests(now_ns);
  send_cycle(now_ns);
}

bool BusCycle::step() {
  window_open_ = false;
  drain();  // anything now is an answer to an older SYNC (late) or asynchronous
  const std::int64_t now_ns = monotonic_ns();
  supervisor_.check_heartbeats(now_ns);
  transmit(now_ns);
  const bool complete = receive_until(monotonic_ns() + config_.step_timeout_ns, [this] { return window_complete(); });
  if (!complete) ++counters_.step_timeouts;
  close_window(monotonic_ns(), true);  // lock-step waited step_timeout_ns for the answers
  return complete;
}

void BusCycle::shutdown() {
  // Brake and switch off cleanly, then leave operational so no RPDO timeout follows.
  window_open_ = false;
  for (int j = 0; j < kDriveCount; ++j)
    send(*drive_bus_, encode_drive_command(DriveCommand{drive_node(j), controlword::kShutdown, 0.0}));
  sync_counter_ = next_sync_counter(sync_counter_);
  send(*drive_bus_, encode_sync(sync_counter_));
  if (separate_sensor_bus_) send(*separate_sensor_bus_, encode_sync(sync_counter_));
  send_nmt_all(NmtCommand::enter_pre_operational);
}

// ---- SDO ---------------------------------------------------------------------------------

SdoResponse BusCycle::sdo_transfer(const SdoRequest& request, const char* what) {
  sdo_response_.reset();
  sdo_waiting_node_ = request.node;
  send(*drive_bus_, encode_sdo_request(request));
  const bool answered = receive_until(monotonic_ns() + config_.sdo_timeout_ns, [&] {
    return sdo_response_ && sdo_response_->index == request.index && sdo_response_->subindex == request.subindex;
  });
  sdo_waiting_node_ = 0;
  char text[96];
  std::snprintf(text, sizeof text, "%s 0x%04x:%02x", what, request.index, request.subindex);
  if (!answered) {
    fail("no SDO response from " + node_description(request.node) + " to " + text + " within " +
         std::to_string(config_.sdo_timeout_ns / 1'000'000) + " ms");
  }
  if (sdo_response_->kind == SdoResponseKind::abort) {
    char code[16];
    std::snprintf(code, sizeof code, "0x%08x", sdo_response_->data);
    fail(node_description(request.node) + " aborted the SDO " + text + " with code " + code);
  }
  return *sdo_response_;
}

}  // namespace rtm::can
