// rtm-actuator: the PA10 driven by Cartesian velocity commands (paper Fig. 7). Owns the CAN
// master (NMT, SYNC every period); in0 = velocity twist (base frame), clamped to ±limit,
// watchdog and NaN/inf give zero velocity.
#include "components/actuator/actuator.h"

#include "rtm/runner.h"

#include <vector>

int main(int argc, char** argv) {
  rtm::comp::ArmHardware::Options hardware;
  hardware.urdf = RTM_PA10_URDF;
  rtm::comp::ActuatorParams params;
  std::vector<float> limit(params.limit.begin(), params.limit.end());
  return rtm::run_component(argc, argv, {
      .kind = "actuator",
      .description =
          "rtm-actuator: PA10 velocity actuator (Fig. 7); in0 = TimedFloat6 twist, base frame "
          "(vx vy vz m/s, wx wy wz rad/s), clamped to ±limit; the CAN master runs (zero velocity) "
          "while the component is off",
      .add_options =
          [&](CLI::App& app) {
            app.add_option("--bus", hardware.bus, "the arm's CAN bus: local:<path> or socketcan:<if>")
                ->capture_default_str();
            app.add_option("--sensor-bus", hardware.sensor_bus, "separate bus of the force sensors (default: --bus)");
            app.add_option("--urdf", hardware.urdf, "arm model for the velocity IK")->capture_default_str();
            app.add_option("--limit", limit, "6 limits: vx vy vz in m/s, wx wy wz in rad/s")
                ->expected(6)
                ->capture_default_str();
            app.add_option("--watchdog-periods", params.watchdog_periods,
                           "cycles without a new command before zero velocity")
                ->capture_default_str();
          },
      .create =
          [&](const rtm::RunSettings& settings) {
            for (std::size_t i = 0; i < 6; ++i) params.limit[i] = limit[i];
            params.validate();
            hardware.period = std::chrono::nanoseconds(settings.period_ns);
            hardware.rt_priority = settings.rt_priority;
            hardware.cpu = settings.cpu;
            return std::make_unique<rtm::comp::Actuator>(
                settings.name, std::make_unique<rtm::comp::ArmHardware>(hardware), params);
          },
  });
}
