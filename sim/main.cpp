// SPDX-License-Identifier: Apache-2.0
// pa10-sim: the MuJoCo PA10 behind a CAN bus, standing in for the real arm's drives and
// force sensors. See sim/README.md.
#include <cmath>
#include <csignal>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <system_error>

#include <CLI/CLI.hpp>

#include "sim/runner.h"

namespace {

std::atomic<bool> g_stop{false};

void on_signal(int) { g_stop.store(true); }

// The scene beside this program: <prefix>/bin/pa10-sim finds <prefix>/share/rtm/models (the
// build tree has the same layout), so an installed tree can move.
std::string default_scene() {
  std::error_code error;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", error);
  if (error) return "pa10_scene.xml";
  return (self.parent_path().parent_path() / "share/rtm/models/pa10_scene.xml").lexically_normal().string();
}

}  // namespace

int main(int argc, char** argv) {
  rtm::sim::RunOptions options;
  options.scene_path = default_scene();
  CLI::App app{"pa10-sim: the simulated PA10-7C arm (MuJoCo) behind a CAN bus"};
  options.buses.bus.clear();  // no default: the simulator serves the bus it is told to
  options.buses.add_options(app);
  app.get_option("--bus")
      ->description("CAN bus: local:<path> (hub created here if none listens) or socketcan:<if>")
      ->required();
  app.add_option("--model", options.scene_path, "MJCF scene")->capture_default_str();
  app.add_flag("--lockstep", options.lock_step,
               "advance one SYNC period (2 ms) per SYNC received, then answer; for tests");
  auto* profile = app.add_option("--profile", options.profile_path,
                                 "operator wrench profile on the joystick (YAML)");
  app.add_flag("--stdin", options.stdin_wrench,
               "read the operator's wrench from stdin lines 'fx fy fz [tx ty tz]' (N, N·m)")
      ->excludes(profile);
  app.add_option("--log", options.log_path, "CSV of the state after each SYNC");
  app.add_option("--duration", options.duration_s, "stop after this much sim time [s]")
      ->check(CLI::Validator(
          [](std::string& text) {
            const double v = std::stod(text);  // CLI::Range lets a NaN through
            return std::isfinite(v) && v >= 0 ? std::string() : "'" + text + "' is not a finite duration >= 0";
          },
          "FINITE >= 0"));
  app.add_option("--velocity-bandwidth", options.velocity_bandwidth_rad_s,
                 "the drives' velocity loop bandwidth, closed-loop -3 dB [rad/s]")
      ->capture_default_str();
  app.add_option("--surface", options.surface,
                 "what the tool presses on: sponge, rubber, wood, steel, or a stiffness in N/m")
      ->capture_default_str()
      ->check(CLI::Validator(
          [](std::string& text) {
            try {
              rtm::sim::parse_surface(text);
              return std::string();
            } catch (const std::invalid_argument& error) {
              return std::string(error.what());
            }
          },
          "SURFACE"));
  app.add_option("--friction", options.friction,
                 "Coulomb friction coefficient of the tool tip on the surface (0: none)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 2.0));
  app.add_flag("--quiet", options.quiet, "no status lines on stdout");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    return app.exit(error) == 0 ? 0 : 2;  // --help: 0; CLI11's own codes (105, 106, ...) are all "bad command line"
  }

  struct sigaction action {};
  action.sa_handler = on_signal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = 0;  // no SA_RESTART: a signal interrupts ppoll at once
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);

  try {
    rtm::sim::run_simulator(options, g_stop);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "pa10-sim: %s\n", error.what());
    return 1;
  }
  return 0;
}
