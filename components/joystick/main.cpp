// SPDX-License-Identifier: Apache-2.0
// rtm-joystick: the reference generator. A passive listener on the joystick force sensor's
// bus; writes the operator's force (base-aligned frame) to out0 each cycle.
#include "components/joystick/joystick.h"

#include "arm/can/bus_options.h"
#include "host/runner.h"

int main(int argc, char** argv) {
  rtm::can::BusOptions buses;
  return rtm::run_component(argc, argv, {
      .kind = "joystick",
      .description =
          "rtm-joystick: force-sensor joystick (reference generator); out0 = TimedFloat6 operator "
          "force, base-aligned frame (Fx Fy Fz N, Tx Ty Tz N·m; pushing down reads -Fz)",
      .add_options =
          [&](CLI::App& app) { buses.add_options(app); },
      .create =
          [&](const rtm::RunSettings& settings) {
            return std::make_unique<rtm::comp::Joystick>(
                settings.name, std::make_unique<rtm::comp::BusJoystickSource>(buses.sensors()));
          },
  });
}
