// SPDX-License-Identifier: Apache-2.0
// rtm-actuator: the PA10 driven by Cartesian velocity commands (paper Fig. 7). Owns the CAN
// master (NMT, SYNC every period); in0 = velocity twist (base frame), clamped to ±limit,
// watchdog and NaN/inf give zero velocity.
#include "components/actuator/actuator.h"

#include "rtm/runner.h"

int main(int argc, char** argv) {
  rtm::comp::ArmHardware::Options hardware;
  rtm::comp::ActuatorParams params;
  return rtm::run_component(argc, argv, {
      .kind = "actuator",
      .description =
          "rtm-actuator: PA10 velocity actuator (Fig. 7); in0 = TimedFloat6 twist, base frame "
          "(vx vy vz m/s, wx wy wz rad/s), clamped to ±limit; the CAN master runs (zero velocity) "
          "while the component is off",
      .add_options =
          [&](CLI::App& app) {
            hardware.add_options(app);
            params.add_options(app);
          },
      .validate = [&](const rtm::RunSettings&) { params.validate(); },
      .create =
          [&](const rtm::RunSettings& settings) {
            hardware.period_ns = settings.period_ns;
            hardware.rt_priority = settings.rt_priority;
            hardware.cpu = settings.cpu;
            return std::make_unique<rtm::comp::Actuator>(
                settings.name, std::make_unique<rtm::comp::ArmHardware>(hardware), params);
          },
  });
}
