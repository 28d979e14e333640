// SPDX-License-Identifier: Apache-2.0
#include "arm/can/supervisor.h"

#include <cstdarg>
#include <cstdio>

namespace rtm::can {

Supervisor::Supervisor(const MasterConfig& config, const std::array<bool, 128>& expected)
    : expected_(expected),
      missed_feedback_limit_(config.missed_feedback_limit),
      heartbeat_timeout_ns_(config.heartbeat_timeout_ns),
      enable_timeout_ns_(config.enable_timeout_ns) {}

// ---- the fault ---------------------------------------------------------------------------

void Supervisor::latch(FaultKind kind, std::uint8_t node, std::uint16_t code, const char* format, ...) {
  if (fault_.active()) return;  // the first cause is the one to report
  fault_.kind = kind;
  fault_.node = node;
  fault_.code = code;
  va_list args;
  va_start(args, format);
  std::vsnprintf(fault_.reason.data(), fault_.reason.size(), format, args);
  va_end(args);
  recovering_ = false;
  enabling_ = false;
}

// ---- phases and requests -------------------------------------------------------------------

void Supervisor::on_nmt_start(std::int64_t now_ns) {
  // Heartbeats sent before the start may still say pre-operational: restart the watch.
  for (auto& heard : last_heartbeat_ns_)
    if (heard != 0) heard = now_ns;
  started_ = true;
  enabling_ = true;
  state_check_from_ns_ = now_ns + heartbeat_timeout_ns_;
}

void Supervisor::take_fault_reset(std::int64_t now_ns) {
  fault_ = FaultRecord{};
  recovering_ = true;
  enabling_ = true;
  missed_.fill(0);
  recovery_deadline_ns_ = now_ns + enable_timeout_ns_;
}

void Supervisor::take_quick_stop(bool requested, std::int64_t now_ns) {
  const bool was_quick_stop = quick_stop_;
  quick_stop_ = requested && !fault_.active() && !enabling_;
  if (was_quick_stop && !quick_stop_) quick_stop_release_deadline_ns_ = now_ns + enable_timeout_ns_;
  if (quick_stop_) quick_stop_release_deadline_ns_ = 0;
}

// A drive in quick stop active is where the master put it, not a drive that left by itself.
bool Supervisor::quick_stop_expected(std::int64_t now_ns) const {
  return quick_stop_ || (quick_stop_release_deadline_ns_ != 0 && now_ns < quick_stop_release_deadline_ns_);
}

std::uint16_t Supervisor::controlword(std::size_t joint, std::uint16_t statusword) {
  if (enabling_) return enablers_[joint].next_controlword(statusword, /*reset_faults=*/true);
  if (quick_stop_ && !fault_.active()) return controlword::kQuickStop;
  // The bus cannot be trusted or a drive moves on its own: brake (the cycle then takes the
  // drives out of operational).
  if (takes_drives_down(fault_.kind)) return controlword::kQuickStop;
  if (fault_.active()) {
    // Hold: enabled drives stay enabled at zero velocity, the others stay off.
    return state_from_statusword(statusword) == DriveState::operation_enabled ? controlword::kEnableOperation
                                                                              : controlword::kDisableVoltage;
  }
  return enablers_[joint].next_controlword(statusword, /*reset_faults=*/false);
}

// ---- frames ------------------------------------------------------------------------------

void Supervisor::on_heartbeat(std::uint8_t node, NmtState state, std::int64_t now_ns) {
  last_heartbeat_ns_[node] = now_ns;
  // A heartbeat sent just before a node processed NMT start may still say pre-operational:
  // the state is checked only once a heartbeat period has passed since the start.
  if (started_ && !enabling_ && now_ns > state_check_from_ns_ && expected_[node] && state != NmtState::operational) {
    latch(FaultKind::node_not_operational, node, static_cast<std::uint16_t>(state),
          "%s: heartbeat reports %s instead of operational", node_description(node).c_str(), to_string(state).data());
  }
}

void Supervisor::on_emcy(std::uint8_t node, std::uint16_t code) {
  // Before NMT start an EMCY belongs to the previous session (a drive that timed out after
  // the last master stopped); the enable sequence resets such a fault. While enabling, too.
  if (code == emcy::kErrorReset || !expected_[node] || !started_ || enabling_) return;
  // A drive's RPDO timeout is its own kind: the commands came late, the drive is not broken.
  const FaultKind kind = code == emcy::kRpdoTimeout ? FaultKind::command_loss : FaultKind::emergency;
  latch(kind, node, code, "%s: EMCY 0x%04x %s", node_description(node).c_str(), code, emcy_description(code).data());
}

// ---- watchdogs -----------------------------------------------------------------------------

void Supervisor::check_heartbeats(std::int64_t now_ns) {
  // Once latched, a fault is not formatted again each cycle (node names may allocate).
  if (!started_ || fault_.active()) return;
  for (unsigned node = 1; node < last_heartbeat_ns_.size(); ++node) {
    if (!expected_[node] || last_heartbeat_ns_[node] == 0) continue;
    const std::int64_t silent_ns = now_ns - last_heartbeat_ns_[node];
    if (silent_ns > heartbeat_timeout_ns_) {
      const auto n = static_cast<std::uint8_t>(node);
      latch(FaultKind::heartbeat_lost, n, 0, "%s: no heartbeat for %lld ms (limit %lld ms)",
            node_description(n).c_str(), static_cast<long long>(silent_ns / 1'000'000),
            static_cast<long long>(heartbeat_timeout_ns_ / 1'000'000));
    }
  }
}

DriveSummary Supervisor::check_drives(const std::array<bool, kDriveCount>& got,
                                      const std::array<std::uint16_t, kDriveCount>& statusword,
                                      std::int64_t now_ns, bool count_silence) {
  DriveSummary summary;
  summary.all_quick_stopped = quick_stop_;
  const bool quick_stop_ok = quick_stop_expected(now_ns);
  for (int j = 0; j < kDriveCount; ++j) {
    const auto i = static_cast<std::size_t>(j);
    if (got[i]) {
      missed_[i] = 0;
    } else if (started_ && count_silence && ++missed_[i] > missed_feedback_limit_ && !fault_.active()) {
      latch(FaultKind::missing_feedback, drive_node(j), 0, "%s: no TPDO for %d consecutive SYNCs",
            node_description(drive_node(j)).c_str(), missed_[i]);
    }
    const auto state = state_from_statusword(statusword[i]);
    const bool quick_stopped = state == DriveState::quick_stop_active;
    const bool enabled = state == DriveState::operation_enabled || (quick_stop_ok && quick_stopped);
    // On the latest statusword: a TPDO that is late (a host stall) does not make the drives
    // not enabled; a drive silent for missed_feedback_limit SYNCs is a fault (above).
    summary.all_enabled = summary.all_enabled && enabled;
    summary.all_quick_stopped = summary.all_quick_stopped && quick_stopped;
    if (enabling_ || !started_ || enabled || fault_.active()) continue;
    check_drive(j, statusword[i]);
  }
  // The grace after a released quick stop (quick_stop_expected) runs to its deadline even once
  // every drive reported operation enabled: a TPDO late by a stall can still carry the quick
  // stop active state of a SYNC before the release.
  check_recovery(statusword, summary.all_enabled, now_ns);
  return summary;
}

// A drive that is neither enabled nor braked on request, outside enabling: a fault.
void Supervisor::check_drive(int joint, std::uint16_t statusword) {
  const auto state = state_from_statusword(statusword);
  const std::uint8_t node = drive_node(joint);
  if (state == DriveState::fault || state == DriveState::fault_reaction_active) {
    latch(FaultKind::drive_fault, node, statusword, "%s: statusword 0x%04x (%s)", node_description(node).c_str(),
          statusword, state ? to_string(*state).data() : "?");
  } else {
    latch(FaultKind::drive_disabled, node, statusword, "%s: left operation enabled, statusword 0x%04x (%s)",
          node_description(node).c_str(), statusword, state ? to_string(*state).data() : "unknown state");
  }
}

void Supervisor::check_recovery(const std::array<std::uint16_t, kDriveCount>& statusword, bool all_enabled,
                                std::int64_t now_ns) {
  if (!recovering_) return;
  if (all_enabled) {
    recovering_ = false;
    enabling_ = false;
    return;
  }
  if (now_ns <= recovery_deadline_ns_) return;
  for (int j = 0; j < kDriveCount; ++j) {
    const auto state = state_from_statusword(statusword[static_cast<std::size_t>(j)]);
    if (state == DriveState::operation_enabled) continue;
    recovering_ = false;
    enabling_ = false;
    latch(FaultKind::drive_fault, drive_node(j), statusword[static_cast<std::size_t>(j)],
          "fault reset failed: %s still %s after %lld ms", node_description(drive_node(j)).c_str(),
          state ? to_string(*state).data() : "in an unknown state",
          static_cast<long long>(enable_timeout_ns_ / 1'000'000));
    return;
  }
}

}  // namespace rtm::can
