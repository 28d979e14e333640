// SPDX-License-Identifier: Apache-2.0
#include "arm/can/fault.h"

namespace rtm::can {

std::string_view to_string(FaultKind kind) {
  switch (kind) {
    case FaultKind::none: return "none";
    case FaultKind::not_enabled: return "not_enabled";
    case FaultKind::drive_fault: return "drive_fault";
    case FaultKind::drive_disabled: return "drive_disabled";
    case FaultKind::emergency: return "emergency";
    case FaultKind::command_loss: return "command_loss";
    case FaultKind::heartbeat_lost: return "heartbeat_lost";
    case FaultKind::bus_error: return "bus_error";
    case FaultKind::missing_feedback: return "missing_feedback";
    case FaultKind::node_not_operational: return "node_not_operational";
    case FaultKind::cycle_owner_lost: return "cycle_owner_lost";
    case FaultKind::foreign_master: return "foreign_master";
    case FaultKind::spoofed_frame: return "spoofed_frame";
    case FaultKind::following_error: return "following_error";
    case FaultKind::ik_failed: return "ik_failed";
  }
  return "invalid";
}

}  // namespace rtm::can
