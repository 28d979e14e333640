// SPDX-License-Identifier: Apache-2.0
// rtm-joystick: the reference generator. A passive listener on the joystick force sensor's
// bus; writes the operator's force (base-aligned frame) to out0 each cycle.
#include "components/joystick/joystick.h"

#include "host/runner.h"

int main(int argc, char** argv) {
  std::string bus = "local:/tmp/rtm-pa10.bus";
  std::string sensor_bus;
  return rtm::run_component(argc, argv, {
      .kind = "joystick",
      .description =
          "rtm-joystick: force-sensor joystick (reference generator); out0 = TimedFloat6 operator "
          "force, base-aligned frame (Fx Fy Fz N, Tx Ty Tz N·m; pushing down reads -Fz)",
      .add_options =
          [&](CLI::App& app) {
            app.add_option("--bus", bus, "the arm's CAN bus: local:<path> or socketcan:<if>")->capture_default_str();
            app.add_option("--sensor-bus", sensor_bus, "separate bus of the force sensors (default: --bus)");
          },
      .create =
          [&](const rtm::RunSettings& settings) {
            return std::make_unique<rtm::comp::Joystick>(
                settings.name, std::make_unique<rtm::comp::BusJoystickSource>(sensor_bus.empty() ? bus : sensor_bus));
          },
  });
}
