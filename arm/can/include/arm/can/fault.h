// SPDX-License-Identifier: Apache-2.0
// The arm's one fault vocabulary, from the CAN master up to the actuator.
//
// The master (Pa10Master, its Supervisor) latches the bus-side kinds; Pa10Arm reports the
// master's kind unchanged and adds the two of its own (not_enabled, ik_failed); the actuator's
// VelocityArm returns the same value. There is no mapping between layers: a kind means the same
// thing wherever it is read. It lives at the bottom (arm/can) so every layer above can name it.
#pragma once

#include "arm/can/protocol.h"

#include <cstdint>
#include <string>
#include <string_view>

namespace rtm::can {

enum class FaultKind : std::uint8_t {
  none,
  // Not latched, clears by itself: the master has not (yet, or again after a fault reset)
  // enabled every drive, or has no feedback yet. Zero velocity meanwhile. Reported by Pa10Arm.
  not_enabled,
  // Latched until a fault reset (zero velocity to every drive meanwhile):
  drive_fault,           // a statusword reports fault / fault reaction, or a fault reset failed
  drive_disabled,        // a drive left operation enabled by itself
  emergency,             // an EMCY with a non-zero code other than command loss
  command_loss,          // a drive's RPDO timeout (EMCY 0x8250): its commands came late (e.g. a
                         // host stall of the master); a communication fault, not a hardware
                         // one: a fault reset brings the drive back
  heartbeat_lost,        // a node silent longer than the heartbeat timeout
  bus_error,             // the transport failed
  missing_feedback,      // a drive did not answer several SYNCs in a row
  node_not_operational,  // a heartbeat reports boot-up/stopped/pre-operational after start
  cycle_owner_lost,      // the thread that took the cycles over stopped running them
  // The three below stop the arm harder than the others: quick stop to every drive, then NMT
  // pre-operational, repeated each cycle, so that RPDOs (ours or anyone's) no longer act.
  foreign_master,        // a SYNC, RPDO, NMT command or SDO write on the bus that we did not send
  spoofed_frame,         // a node sent more TPDOs than it was asked for: another sender uses its id
  following_error,       // a drive's actual velocity or position left the window around our command
  ik_failed,             // Pa10Arm: the twist (or the measured q) was not finite
};

// The kind's name as written above ("drive_fault", "command_loss", ...).
std::string_view to_string(FaultKind kind);

// A fault as every layer reports it: the master, the listeners, the force sources, the arm.
struct Fault {
  FaultKind kind = FaultKind::none;
  std::uint8_t node = 0;  // the node it concerns (0: the bus, none, or the reporter cannot tell)
  std::uint16_t code = 0; // the EMCY code or statusword it came with (0: none)
  std::string reason;     // one line naming the node and what happened; "" for none
  bool active() const { return kind != FaultKind::none; }
};

// A fault that holds until a reset: anything but none and not_enabled.
constexpr bool latched(FaultKind kind) { return kind != FaultKind::none && kind != FaultKind::not_enabled; }

// A fault that takes the drives out of operational (see foreign_master above): the bus cannot be
// trusted, or a drive moves on something other than our command.
constexpr bool takes_drives_down(FaultKind kind) {
  return kind == FaultKind::foreign_master || kind == FaultKind::spoofed_frame || kind == FaultKind::following_error;
}

// What the layer above may do about a fault, by its kind and the node it concerns: the arm
// library's knowledge, so that no component decides which faults are the hardware's.
enum class Recovery : std::uint8_t {
  none,           // nothing latched (none, not_enabled): go on
  reset,          // a communication fault, nothing broken (command_loss: commands came late;
                  // cycle_owner_lost: a late tick lost the bus cycles): reset, move again on the
                  // next new command
  reset_a_few,    // missing_feedback: drives silent for a few SYNCs with their heartbeat on (a
                  // stall of the process that runs them); reset, but a drive that keeps doing it
                  // answers no SYNC: the caller bounds how often
  wait_for_node,  // heartbeat_lost of a force sensor node: the drives are stopped; reset now and
                  // then while the caller's budget for its silence lasts
  stop,           // anything else: the drives or the bus are not to be trusted; stay stopped
};

constexpr Recovery recovery(FaultKind kind, std::uint8_t node) {
  switch (kind) {
    case FaultKind::none:
    case FaultKind::not_enabled: return Recovery::none;
    case FaultKind::command_loss:
    case FaultKind::cycle_owner_lost: return Recovery::reset;
    case FaultKind::missing_feedback: return Recovery::reset_a_few;
    case FaultKind::heartbeat_lost: return is_sensor_node(node) ? Recovery::wait_for_node : Recovery::stop;
    default: return Recovery::stop;
  }
}

inline Recovery recovery(const Fault& fault) { return recovery(fault.kind, fault.node); }

}  // namespace rtm::can
