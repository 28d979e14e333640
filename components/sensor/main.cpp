// SPDX-License-Identifier: Apache-2.0
// rtm-sensor: the wrist force/torque sensor as an RT component (paper Fig. 5). A passive
// listener on the arm's bus: it reads the wrist sensor's TPDOs and the drives' joint
// positions, and writes the wrench in the arm's base frame to out0 each cycle. A heartbeat
// loss of the sensor node is waited out for --recovery-timeout-periods cycles, writing nothing.
#include "components/sensor/sensor.h"

#include "arm/can/bus_options.h"
#include "host/runner.h"

int main(int argc, char** argv) {
  rtm::can::BusOptions buses;
  std::string urdf;  // "" = the arm library's built-in PA10 model
  rtm::comp::SensorParams params;
  return rtm::run_component(argc, argv, {
      .kind = "sensor",
      .description =
          "rtm-sensor: wrist F/T sensor; out0 = TimedFloat6 wrench on the tool, base frame "
          "(Fx Fy Fz N, Tx Ty Tz N·m; pressing on the table reads +Fz)",
      .add_options =
          [&](CLI::App& app) {
            buses.add_options(app);
            app.add_option("--urdf", urdf, "arm model URDF, for the sensor frame's orientation (default: the built-in PA10 model)");
            rtm::add_parameter_options(app, rtm::comp::sensor_parameters(), params);
          },
      .validate = [&](const rtm::RunSettings&) { params.validate(); },
      .create =
          [&](const rtm::RunSettings& settings) {
            return std::make_unique<rtm::comp::Sensor>(
                settings.name, std::make_unique<rtm::comp::BusWristSource>(buses.bus, buses.sensor_bus),
                rtm::pa10::Kinematics::pa10(urdf), params);
          },
  });
}
