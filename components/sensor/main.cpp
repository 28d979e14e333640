// SPDX-License-Identifier: Apache-2.0
// rtm-sensor and rtm-joystick: a force/torque sensor of the arm's bus as an RT component, the
// wrist's (paper Fig. 5) or the operator's joystick (the reference generator). Both are this
// file: rtm-joystick is built with RTM_SENSOR_JOYSTICK and reads the joystick node; rtm-sensor
// reads the node --node names (default the wrist). A passive listener: it reads the node's
// TPDOs (the wrist sensor: and the drives' joint positions, to turn the wrench into the arm's
// base frame) and writes each new wrench to out0. A heartbeat loss of the node is waited out
// for --recovery-timeout-periods cycles, writing nothing.
#include "components/sensor/sensor.h"

#include "arm/can/bus_options.h"
#include "host/module.h"

#include <memory>
#include <string>

namespace {

namespace pc = rtm::can;

#ifdef RTM_SENSOR_JOYSTICK
constexpr bool kJoystickOnly = true;
#else
constexpr bool kJoystickOnly = false;
#endif

rtm::ComponentMain sensor() {
  struct Options {
    pc::BusOptions buses;
    std::string node_name = kJoystickOnly ? "joystick" : "wrist";
    std::string urdf;  // "" = the arm library's built-in PA10 model
    rtm::comp::SensorParams params;
  };
  auto options = std::make_shared<Options>();
  return {
      .kind = kJoystickOnly ? "joystick" : "sensor",
      .description =
          kJoystickOnly
              ? "rtm-joystick: force-sensor joystick (reference generator, node 0x11); out0 = TimedFloat6 operator "
                "force, base-aligned frame (Fx Fy Fz N, Tx Ty Tz N·m; pushing down reads -Fz)"
              : "rtm-sensor: a force/torque sensor of the arm's bus; out0 = TimedFloat6 wrench in the base frame "
                "(Fx Fy Fz N, Tx Ty Tz N·m): --node wrist (0x10, the default), the wrench on the tool (pressing on "
                "the table reads +Fz), or --node joystick (0x11), the operator's force (as rtm-joystick)",
      .add_options =
          [options](CLI::App& app) {
            auto& [buses, node_name, urdf, params] = *options;
            buses.add_options(app);
            if (!kJoystickOnly) {
              app.add_option("--node", node_name, "which force sensor: wrist (0x10) or joystick (0x11)")
                  ->check(CLI::IsMember({"wrist", "joystick"}))
                  ->capture_default_str();
              app.add_option("--urdf", urdf,
                             "arm model URDF, for the wrist sensor frame's orientation (default: the built-in PA10 "
                             "model)");
            }
            rtm::add_parameter_options(app, rtm::comp::sensor_parameters(), params);
          },
      .validate = [options](const rtm::RunSettings&) { options->params.validate(); },
      .create =
          [options](const rtm::RunSettings& settings) -> std::unique_ptr<rtm::Component> {
            auto& [buses, node_name, urdf, params] = *options;
            if (node_name == "joystick")
              return rtm::comp::Sensor::joystick(
                  settings.name, std::make_unique<rtm::comp::BusForceSource>(buses.sensors(), pc::ForceSensor::joystick),
                  params);
            return rtm::comp::Sensor::wrist(
                settings.name,
                std::make_unique<rtm::comp::BusForceSource>(buses.sensors(), pc::ForceSensor::wrist, buses.bus),
                rtm::pa10::Kinematics::pa10(urdf), params);
          },
      .budget_ns = kJoystickOnly ? rtm::comp::kJoystickBudgetNs : rtm::comp::kWristSensorBudgetNs,
  };
}

}  // namespace

RTM_COMPONENT(sensor)
