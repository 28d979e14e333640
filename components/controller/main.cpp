// rtm-controller: the proportional force controller (paper Fig. 6):
// out0 = gain * (in1 reference + in0 sensor), zero when an input is stale or not finite.
#include "components/controller/controller.h"

#include "rtm/runner.h"

#include <vector>

int main(int argc, char** argv) {
  rtm::comp::ControllerParams params;
  std::vector<float> gain(params.gain.begin(), params.gain.end());
  return rtm::run_component(argc, argv, {
      .kind = "controller",
      .description =
          "rtm-controller: P force controller, out0 = gain*(in1 + in0) (Fig. 6); in0 sensor wrench, "
          "in1 reference wrench, out0 velocity twist (base frame, m/s, rad/s)",
      .add_options =
          [&](CLI::App& app) {
            app.add_option("--gain", gain, "6 gains: x y z in (m/s)/N, rx ry rz in (rad/s)/(N·m)")
                ->expected(6)
                ->capture_default_str();
            app.add_option("--stale-periods", params.stale_periods,
                           "cycles without a new input datum before the command is zero")
                ->capture_default_str();
          },
      .create =
          [&](const rtm::RunSettings& settings) {
            for (std::size_t i = 0; i < 6; ++i) params.gain[i] = gain[i];
            return std::make_unique<rtm::comp::Controller>(settings.name, params);
          },
  });
}
