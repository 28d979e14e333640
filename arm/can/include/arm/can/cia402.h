// SPDX-License-Identifier: Apache-2.0
// The CiA 402 drive state machine as pure value types, one per side of the bus.
//
// Device side (pa10-sim, test fakes): `Cia402Drive` takes controlwords and faults and gives the
// state and the statusword to report. Master side: `Cia402Enabler` looks at a drive's
// statusword and says which controlword to send next to reach "operation enabled" (and, only
// when asked, produces the rising edge of bit 7 that resets a fault). No I/O, no clocks.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

#include "arm/can/protocol.h"

namespace rtm::can {

enum class DriveState : std::uint8_t {
  not_ready_to_switch_on,
  switch_on_disabled,
  ready_to_switch_on,
  switched_on,
  operation_enabled,
  quick_stop_active,
  fault_reaction_active,
  fault,
};
std::string_view to_string(DriveState state);

// The state a statusword reports (CiA 402 masks: 0x004F for not-ready/disabled/fault states,
// 0x006F for the others); nullopt for a bit pattern that is no state.
std::optional<DriveState> state_from_statusword(std::uint16_t statusword);
// The canonical statusword of a state (the values in protocol.h's `statusword` namespace).
std::uint16_t statusword_of(DriveState state);

// The command a controlword carries (bits 0-3 and 7, CiA 402 table); fault reset is reported
// separately because it acts on the rising edge of bit 7, not on the level.
enum class DriveCommandWord : std::uint8_t {
  disable_voltage,
  quick_stop,
  shutdown,
  switch_on,          // also "disable operation" when in operation enabled
  enable_operation,   // switch on + enable operation
  none,               // a pattern with no command (e.g. only bit 7)
};
DriveCommandWord command_of(std::uint16_t controlword);

// ---- device side -------------------------------------------------------------------------

class Cia402Drive {
 public:
  // After power-up a drive passes "not ready to switch on" by itself; it starts here in
  // "switch on disabled", where the master finds it.
  Cia402Drive() = default;

  DriveState state() const { return state_; }
  std::uint16_t statusword() const { return statusword_of(state_); }
  // Only in operation enabled does the drive follow target_velocity; otherwise it holds zero.
  bool follows_target_velocity() const { return state_ == DriveState::operation_enabled; }

  // Applies one received controlword (the value latched at SYNC). Transitions per CiA 402:
  // shutdown 2/6/8, switch on 3, enable operation 4 (and 3+4 from ready to switch on),
  // disable operation 5, disable voltage 7/9/10/12, quick stop 7/10/11, quick stop -> enable
  // 16, fault reset 15 on the rising edge of bit 7 while in fault. Commands are ignored in
  // fault (except the reset) and in fault reaction active.
  void apply_controlword(std::uint16_t controlword);

  // A fault (RPDO timeout, hardware, …) takes the drive to "fault" from any state. The
  // device brakes and reports statusword 0x0008 until a fault reset.
  void raise_fault();
  // Back to switch on disabled, as after power-up or NMT reset node.
  void reset();

 private:
  DriveState state_ = DriveState::switch_on_disabled;
  bool last_fault_reset_bit_ = false;
};

// ---- master side -------------------------------------------------------------------------

class Cia402Enabler {
 public:
  // The controlword to send next for a drive that reports `statusword`, on the way to
  // operation enabled: disabled -> shutdown, ready -> switch on, switched on / enabled ->
  // enable operation, quick stop active -> enable operation (transition 16: straight back to
  // operation enabled; the master sends quick stop itself while it wants it), not ready / fault reaction ->
  // disable voltage (wait). In fault: with `reset_faults` false, disable voltage (stay in
  // fault); with true, alternates 0x0000 / 0x0080 so the drive sees a rising edge of bit 7.
  // An unknown bit pattern gives disable voltage.
  std::uint16_t next_controlword(std::uint16_t statusword, bool reset_faults);

  std::uint16_t last_controlword() const { return last_; }

 private:
  std::uint16_t last_ = controlword::kDisableVoltage;
};

}  // namespace rtm::can
