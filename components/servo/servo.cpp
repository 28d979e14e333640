// SPDX-License-Identifier: Apache-2.0
#include "components/servo/servo.h"

namespace rtm::comp {

rtm::Diagram servo_diagram(const std::string& servo, const std::string& sensor, const std::string& controller,
                           const std::string& actuator, bool ticked, std::int64_t phase_offset_ns) {
  return {.name = servo + "'s wiring",
          .members = {{sensor, 0}, {controller, phase_offset_ns}, {actuator, 2 * phase_offset_ns}},
          .ticked = ticked,
          .connections = {{{sensor, "wrench"}, {controller, "wrench"}}, {{controller, "twist"}, {actuator, "twist"}}}};
}

}  // namespace rtm::comp
