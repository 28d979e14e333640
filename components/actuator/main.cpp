// SPDX-License-Identifier: Apache-2.0
// rtm-actuator: the PA10 driven by Cartesian velocity commands (paper Fig. 7). Owns the CAN
// master (NMT, SYNC every period); in0 = velocity twist (base frame), clamped to ±limit,
// the watchdog and NaN/inf give a CiA 402 quick stop (the drives brake).
#include "components/actuator/actuator.h"

#include "host/module.h"

#include <memory>

namespace {
// With --phase: the bus cycle runs this long after the actuator's cycle (its wake-up lateness
// and the velocity IK fit well inside on these machines: p99 ~100 us).
constexpr std::int64_t kMasterLeadNs = 150'000;

rtm::ComponentMain actuator() {
  struct Options {
    rtm::pa10::ArmHardware::Options hardware;
    rtm::comp::ActuatorParams params;
  };
  auto options = std::make_shared<Options>();
  return {
      .kind = "actuator",
      .description =
          "rtm-actuator: PA10 velocity actuator (Fig. 7); in0 = TimedFloat6 twist, base frame "
          "(vx vy vz m/s, wx wy wz rad/s), clamped to ±limit; the CAN master runs (zero velocity) "
          "while the component is off",
      .add_options =
          [options](CLI::App& app) {
            auto& [hardware, params] = *options;
            hardware.add_options(app);
            rtm::add_parameter_options(app, rtm::comp::actuator_parameters(), params);
          },
      .validate = [options](const rtm::RunSettings&) { options->params.validate(); },
      .create =
          [options](const rtm::RunSettings& settings) {
            auto& [hardware, params] = *options;
            hardware.period_ns = settings.period_ns;
            hardware.rt_priority = settings.rt_priority;
            hardware.cpu = settings.cpu;
            // With --phase the bus cycles share the components' grid, kMasterLead after the
            // actuator's own cycle: each SYNC carries the command that cycle just handed over.
            if (settings.phase_ns)
              hardware.master_first_deadline_ns =
                  settings.period_ns + (*settings.phase_ns + kMasterLeadNs) % settings.period_ns;
            return std::make_unique<rtm::comp::Actuator>(
                settings.name, std::make_unique<rtm::pa10::ArmHardware>(hardware), params);
          },
      .budget_ns = rtm::comp::kActuatorBudgetNs,
  };
}

}  // namespace

RTM_COMPONENT(actuator)
