// SPDX-License-Identifier: Apache-2.0
#include "arm/can/cia402.h"

namespace rtm::can {

std::string_view to_string(DriveState state) {
  switch (state) {
    case DriveState::not_ready_to_switch_on: return "not ready to switch on";
    case DriveState::switch_on_disabled: return "switch on disabled";
    case DriveState::ready_to_switch_on: return "ready to switch on";
    case DriveState::switched_on: return "switched on";
    case DriveState::operation_enabled: return "operation enabled";
    case DriveState::quick_stop_active: return "quick stop active";
    case DriveState::fault_reaction_active: return "fault reaction active";
    case DriveState::fault: return "fault";
  }
  return "invalid";
}

std::optional<DriveState> state_from_statusword(std::uint16_t sw) {
  // CiA 402 table 30: the first four states ignore bit 5 (quick stop).
  switch (sw & 0x004F) {
    case 0x0000: return DriveState::not_ready_to_switch_on;
    case 0x0040: return DriveState::switch_on_disabled;
    case 0x000F: return DriveState::fault_reaction_active;
    case 0x0008: return DriveState::fault;
    default: break;
  }
  switch (sw & statusword::kStateMask) {
    case statusword::kReadyToSwitchOn: return DriveState::ready_to_switch_on;
    case statusword::kSwitchedOn: return DriveState::switched_on;
    case statusword::kOperationEnabled: return DriveState::operation_enabled;
    case statusword::kQuickStopActive: return DriveState::quick_stop_active;
    default: return std::nullopt;
  }
}

std::uint16_t statusword_of(DriveState state) {
  switch (state) {
    case DriveState::not_ready_to_switch_on: return statusword::kNotReadyToSwitchOn;
    case DriveState::switch_on_disabled: return statusword::kSwitchOnDisabled;
    case DriveState::ready_to_switch_on: return statusword::kReadyToSwitchOn;
    case DriveState::switched_on: return statusword::kSwitchedOn;
    case DriveState::operation_enabled: return statusword::kOperationEnabled;
    case DriveState::quick_stop_active: return statusword::kQuickStopActive;
    case DriveState::fault_reaction_active: return statusword::kFaultReactionActive;
    case DriveState::fault: return statusword::kFault;
  }
  return statusword::kNotReadyToSwitchOn;
}

DriveCommandWord command_of(std::uint16_t cw) {
  // CiA 402 table 28; bit 7 (fault reset) is an edge, handled by the caller.
  if ((cw & 0x0082) == 0x0000) return DriveCommandWord::disable_voltage;
  if ((cw & 0x0086) == 0x0002) return DriveCommandWord::quick_stop;
  if ((cw & 0x0087) == 0x0006) return DriveCommandWord::shutdown;
  if ((cw & 0x008F) == 0x0007) return DriveCommandWord::switch_on;
  if ((cw & 0x008F) == 0x000F) return DriveCommandWord::enable_operation;
  return DriveCommandWord::none;
}

void Cia402Drive::apply_controlword(std::uint16_t cw) {
  const bool reset_bit = (cw & controlword::kFaultResetBit) != 0;
  const bool rising_edge = reset_bit && !last_fault_reset_bit_;
  last_fault_reset_bit_ = reset_bit;

  if (state_ == DriveState::fault) {
    if (rising_edge) state_ = DriveState::switch_on_disabled;  // transition 15
    return;
  }
  if (state_ == DriveState::fault_reaction_active || state_ == DriveState::not_ready_to_switch_on) {
    return;  // the drive leaves these by itself
  }

  using C = DriveCommandWord;
  const C command = command_of(cw);
  switch (state_) {
    case DriveState::switch_on_disabled:
      if (command == C::shutdown) state_ = DriveState::ready_to_switch_on;  // 2
      break;
    case DriveState::ready_to_switch_on:
      if (command == C::switch_on) state_ = DriveState::switched_on;  // 3
      else if (command == C::enable_operation) state_ = DriveState::operation_enabled;  // 3+4
      else if (command == C::disable_voltage || command == C::quick_stop) {
        state_ = DriveState::switch_on_disabled;  // 7
      }
      break;
    case DriveState::switched_on:
      if (command == C::enable_operation) state_ = DriveState::operation_enabled;  // 4
      else if (command == C::shutdown) state_ = DriveState::ready_to_switch_on;  // 6
      else if (command == C::disable_voltage || command == C::quick_stop) {
        state_ = DriveState::switch_on_disabled;  // 10
      }
      break;
    case DriveState::operation_enabled:
      if (command == C::switch_on) state_ = DriveState::switched_on;  // 5
      else if (command == C::shutdown) state_ = DriveState::ready_to_switch_on;  // 8
      else if (command == C::disable_voltage) state_ = DriveState::switch_on_disabled;  // 9
      else if (command == C::quick_stop) state_ = DriveState::quick_stop_active;  // 11
      break;
    case DriveState::quick_stop_active:
      if (command == C::disable_voltage) state_ = DriveState::switch_on_disabled;  // 12
      else if (command == C::enable_operation) state_ = DriveState::operation_enabled;  // 16
      break;
    default: break;
  }
}

void Cia402Drive::raise_fault() { state_ = DriveState::fault; }

void Cia402Drive::reset() {
  state_ = DriveState::switch_on_disabled;
  last_fault_reset_bit_ = false;
}

std::uint16_t Cia402Enabler::next_controlword(std::uint16_t sw, bool reset_faults) {
  std::uint16_t next = controlword::kDisableVoltage;
  if (const auto state = state_from_statusword(sw)) {
    switch (*state) {
      case DriveState::switch_on_disabled: next = controlword::kShutdown; break;
      case DriveState::ready_to_switch_on: next = controlword::kSwitchOn; break;
      case DriveState::switched_on:
      case DriveState::operation_enabled:
      case DriveState::quick_stop_active: next = controlword::kEnableOperation; break;  // 4, 16
      case DriveState::fault:
        // The reset acts on the rising edge: after a word with bit 7 comes one without.
        if (reset_faults && (last_ & controlword::kFaultResetBit) == 0) {
          next = controlword::kFaultResetBit;
        }
        break;
      case DriveState::not_ready_to_switch_on:
      case DriveState::fault_reaction_active: break;
    }
  }
  last_ = next;
  return next;
}

}  // namespace rtm::can
