// SPDX-License-Identifier: Apache-2.0
#include "arm/can/startup.h"

#include <string>

namespace rtm::can {

namespace {

void wait_for_every_node(BusCycle& cycle) {
  Supervisor& sup = cycle.supervisor();
  const auto all_seen = [&] {
    for (unsigned n = 1; n < 128; ++n) {
      const auto node = static_cast<std::uint8_t>(n);
      if (sup.node_expected(node) && !sup.heard_from(node)) return false;
    }
    return true;
  };
  if (cycle.receive_until(monotonic_ns() + cycle.config().boot_timeout_ns, all_seen)) return;
  std::string missing;
  for (unsigned n = 1; n < 128; ++n) {
    const auto node = static_cast<std::uint8_t>(n);
    if (!sup.node_expected(node) || sup.heard_from(node)) continue;
    if (!missing.empty()) missing += ", ";
    missing += node_description(n);
  }
  cycle.fail("no boot-up or heartbeat within " + std::to_string(cycle.config().boot_timeout_ns / 1'000'000) + " ms from " +
             missing);
}

void set_velocity_mode(BusCycle& cycle) {
  for (int j = 0; j < kDriveCount; ++j) {
    const std::uint8_t node = drive_node(j);
    cycle.sdo_transfer(SdoRequest{node, SdoRequestKind::download, object::kModesOfOperation, 0,
                                  static_cast<std::uint8_t>(object::kCyclicSynchronousVelocityMode), 1},
                       "write mode of operation");
    const SdoResponse mode = cycle.sdo_transfer(
        SdoRequest{node, SdoRequestKind::upload, object::kModesOfOperationDisplay, 0, 0, 0},
        "read mode of operation display");
    const auto value = static_cast<std::int8_t>(mode.data & 0xFF);
    if (mode.kind != SdoResponseKind::upload_data || value != object::kCyclicSynchronousVelocityMode) {
      cycle.fail(node_description(node) + ": mode of operation display 0x6061 reads " + std::to_string(value) +
                 " after writing 9 (cyclic synchronous velocity)");
    }
  }
}

bool every_drive_enabled(const BusCycle& cycle) {
  for (std::size_t i = 0; i < kDriveCount; ++i)
    if (!cycle.answered(i) || state_from_statusword(cycle.statusword(i)) != DriveState::operation_enabled)
      return false;
  return true;
}

std::string drives_not_enabled(const BusCycle& cycle) {
  std::string states;
  for (int j = 0; j < kDriveCount; ++j) {
    const auto i = static_cast<std::size_t>(j);
    const auto state = state_from_statusword(cycle.statusword(i));
    if (cycle.answered(i) && state == DriveState::operation_enabled) continue;
    if (!states.empty()) states += ", ";
    states += node_description(drive_node(j)) + " " +
              (cycle.answered(i) ? std::string(state ? to_string(*state) : "unknown state")
                                 : std::string("not answering"));
  }
  return states;
}

void enable_drives(BusCycle& cycle) {
  const std::int64_t period_ns = cycle.config().period_ns;
  const std::int64_t enable_deadline_ns = monotonic_ns() + cycle.config().enable_timeout_ns;
  std::int64_t next_ns = monotonic_ns();
  for (;;) {
    cycle.step();
    const FaultRecord& fault = cycle.supervisor().fault();
    if (fault.active()) cycle.fail(std::string("fault while enabling: ") + fault.reason.data());
    if (every_drive_enabled(cycle)) return;
    if (monotonic_ns() > enable_deadline_ns) {
      cycle.fail("drives not in operation enabled within " + std::to_string(cycle.config().enable_timeout_ns / 1'000'000) +
                 " ms: " + drives_not_enabled(cycle));
    }
    next_ns += period_ns;
    sleep_until_ns(next_ns);
  }
}

}  // namespace

void run_startup(BusCycle& cycle) {
  if (cycle.supervisor().started()) cycle.fail("start() called twice");
  wait_for_every_node(cycle);
  // Configuration happens in pre-operational (nodes left operational go back there).
  cycle.send_nmt_all(NmtCommand::enter_pre_operational);
  set_velocity_mode(cycle);
  // Operational: PDOs flow from the next SYNC on.
  cycle.send_nmt_all(NmtCommand::start);
  cycle.supervisor().on_nmt_start(monotonic_ns());
  enable_drives(cycle);
  cycle.supervisor().enabled_at_startup();
  cycle.publish_now(true);
}

}  // namespace rtm::can
