// SPDX-License-Identifier: Apache-2.0
// rtm-controller: the proportional force controller (paper Fig. 6):
// out0 = gain * (in1 reference + in0 sensor); no command while an input is stale or not
// finite (the actuator's watchdog then brakes).
#include "components/controller/controller.h"

#include "host/module.h"

#include <memory>

namespace {

rtm::ComponentMain controller() {
  auto params = std::make_shared<rtm::comp::ControllerParams>();
  return {
      .kind = "controller",
      .description =
          "rtm-controller: P force controller, out0 = gain*(in1 + in0) (Fig. 6); in0 sensor wrench, "
          "in1 reference wrench, out0 velocity twist (base frame, m/s, rad/s)",
      .add_options = [params](CLI::App& app) { rtm::add_parameter_options(app, rtm::comp::controller_parameters(), *params); },
      .validate = [params](const rtm::RunSettings&) { params->validate(); },
      .create = [params](const rtm::RunSettings& settings) {
        return std::make_unique<rtm::comp::Controller>(settings.name, *params);
      },
      .budget_ns = rtm::comp::kControllerBudgetNs,
  };
}

}  // namespace

RTM_COMPONENT(controller)
