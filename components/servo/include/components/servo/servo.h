// SPDX-License-Identifier: Apache-2.0
// Servo: the composite of the paper (Figs. 4, 8). What it is, is a declaration: its three
// members in the order a cycle runs them, and their wiring by port name:
//
//   sensor.wrench -> controller.wrench,  controller.twist -> actuator.twist
//
// Its own InPort 0 IS the controller's InPort "reference": the servo's servant hands out the
// controller's (ComponentServant::expose_in_port), so a put on it lands directly in the
// controller.
//
// The host runs the declaration in either of two ways (rtm-servo, main.cpp):
//   rtm::RemoteComposite  the paper's: members are RT components anywhere (found by name), each
//                         on its own periodic activity, phased a quarter period apart;
//   rtm::TickedComposite  members live in this process, and one shared tick runs the CAN
//                         master's receive, sensor -> controller -> actuator, and its transmit
//                         every period, so a sensor sample reaches the drives with the SYNC of
//                         the same cycle.
// Either checks the diagram against the members' ports before anything is wired.
#pragma once

#include "rtm/diagram.h"

#include <cstdint>
#include <string>

namespace rtm::comp {

// The servo's diagram. ticked: one thread runs the members in the listed order (a shared
// tick). phase_offset_ns (not ticked): the members' cycles that far apart, sensor first, so
// each finds the datum its upstream member produced a phase earlier; 0: no phases.
rtm::Diagram servo_diagram(const std::string& servo, const std::string& sensor, const std::string& controller,
                           const std::string& actuator, bool ticked, std::int64_t phase_offset_ns = 0);
// The controller's InPort the servo hands out as its own.
inline constexpr const char* kServoReferencePort = "reference";

}  // namespace rtm::comp
