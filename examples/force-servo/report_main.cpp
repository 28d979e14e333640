// SPDX-License-Identifier: Apache-2.0
// rtm-demo-report: the force-servo demo's recordings in, its summary, merged CSV and gnuplot
// script out.
//
//   rtm-demo-report --reference joystick.csv --sensor sensor.csv --command controller.csv
//                   [--timing timing.json] [--script-phases phases.csv --pose pose.csv] --out DIR
//   rtm-demo-report live --seconds N --reference ... --sensor ... --command ...
//
// Writes DIR/force_servo.csv, DIR/force_servo.gp (draws DIR/force_servo.png) and
// DIR/summary.txt, and prints the summary. Exit 0 on success, 1 for unusable input,
// 2 for a bad command line, 3 with --check when a figure the demo promises (demo_report.h:
// touch-down overshoot, settling, release transitions, watchdog events; steady-state error,
// overruns; a motion script's slides: script_report.h) is missed or cannot be measured.
//
// live: the demo's display while it runs, one line a second for N seconds on one
// CLOCK_MONOTONIC grid, from the newest complete row of each recording (demo_report.h). One
// process reading three file tails a second, where the demo's shell loop once started a dozen
// commands a second for it.
#include "demo_report.h"
#include "script_report.h"

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <time.h>

#include <cerrno>
#include <cstdio>
#include <fstream>
#include <string_view>

namespace {

int run_live(int argc, char** argv) {
  CLI::App app{"rtm-demo-report live: the demo's live line, once a second"};
  int seconds = 0;
  std::string reference_csv, sensor_csv, command_csv;
  app.add_option("--seconds", seconds, "lines to print, one a second")->required()->check(CLI::PositiveNumber);
  app.add_option("--reference", reference_csv, "rtm watch --csv of the joystick's out0")->required();
  app.add_option("--sensor", sensor_csv, "rtm watch --csv of the wrist sensor's out0")->required();
  app.add_option("--command", command_csv, "rtm watch --csv of the controller's out0")->required();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    return app.exit(error) == 0 ? 0 : 2;
  }
  timespec next{};
  clock_gettime(CLOCK_MONOTONIC, &next);
  const rtm::demo::Row none{};
  for (int t = 1; t <= seconds; ++t) {
    ++next.tv_sec;
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr) == EINTR) {
    }
    const auto reference = rtm::demo::last_complete_row_of(reference_csv);
    const auto sensor = rtm::demo::last_complete_row_of(sensor_csv);
    const auto command = rtm::demo::last_complete_row_of(command_csv);
    fmt::print("{}\n", rtm::demo::live_line(t, reference.value_or(none), sensor.value_or(none), command.value_or(none)));
    std::fflush(stdout);
  }
  return 0;
}

// The figures' limits and the contact threshold (demo_report.h); --max-overshoot is in %.
void add_figure_options(CLI::App& app, rtm::demo::PhaseOptions& options, rtm::demo::FigureLimits& limits,
                        double& max_overshoot_percent) {
  app.add_option("--contact", options.contact_threshold_N, "contact (touch-down) threshold on the force, N")
      ->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option("--max-overshoot", max_overshoot_percent, "touch-down overshoot limit, %")
      ->capture_default_str()->check(CLI::NonNegativeNumber);
  app.add_option("--max-touch-down-settling", limits.max_touch_down_settling_s,
                 "limit on the settling time after a touch-down, s")
      ->capture_default_str()->check(CLI::NonNegativeNumber);
  app.add_option("--max-step-settling", limits.max_step_settling_s,
                 "limit on the settling time after a reference step in contact, s")
      ->capture_default_str()->check(CLI::NonNegativeNumber);
  app.add_option("--release-level", limits.release_level_N, "force level whose crossings count at release, N")
      ->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option("--max-release-transitions", limits.max_release_transitions,
                 "limit on the touch/lift transitions after the last press")
      ->capture_default_str()->check(CLI::NonNegativeNumber);
  app.add_option("--max-watchdog-events", limits.max_watchdog_events, "limit on the actuator's watchdog events")
      ->capture_default_str()->check(CLI::NonNegativeNumber);
  app.add_option("--explained-watchdog-events", limits.explained_watchdog_events,
                 "of the watchdog events, those a host stall explains (the demo's witness): the limit applies to "
                 "the others")
      ->check(CLI::NonNegativeNumber);
}

// A motion script's run: its phase log and the tool's pose (script_report.h).
struct ScriptInputs {
  std::string phases_csv, pose_csv;
  rtm::demo::ScriptLimits limits;
  double max_deviation_mm = rtm::demo::ScriptLimits{}.max_deviation_m * 1000;
};

void add_script_options(CLI::App& app, ScriptInputs& script) {
  app.add_option("--script-phases", script.phases_csv,
                 "a motion script's phase log (rtm script --phases): its motions and each slide's force error and path")
      ->check(CLI::ExistingFile);
  app.add_option("--pose", script.pose_csv, "rtm watch --csv of the actuator's pose (the path of a slide)")
      ->check(CLI::ExistingFile);
  app.add_option("--max-slide-force-error", script.limits.max_force_error_p99_N,
                 "limit on a slide's force error along the normal, p99, N")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--max-path-deviation", script.max_deviation_mm, "limit on a slide's distance from its straight line, mm")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
}

// The summary's part on the script; what it misses goes to `missed`.
std::string script_summary(const ScriptInputs& script, const std::string& sensor_csv, std::vector<std::string>& missed) {
  const auto phases = rtm::demo::read_script_phases(script.phases_csv);
  const auto sensor = rtm::demo::read_watch_csv(sensor_csv);
  const auto pose = script.pose_csv.empty() ? rtm::demo::Series{} : rtm::demo::read_watch_csv(script.pose_csv);
  std::vector<rtm::demo::SlideFigures> slides;
  for (const auto& p : phases)
    if (p.motion == "slide") slides.push_back(rtm::demo::slide_figures(p, sensor, pose));
  return rtm::demo::format_script_report(phases, slides, script.limits, missed);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc > 1 && std::string_view(argv[1]) == "live") return run_live(argc - 1, argv + 1);
  CLI::App app{"rtm-demo-report: summary, CSV and plot of a force-servo demo recording"};
  std::string reference_csv, sensor_csv, command_csv, timing_json, out_dir;
  bool check = false;
  rtm::demo::PhaseOptions options;
  app.add_option("--reference", reference_csv, "rtm watch --csv of the joystick's out0")->required()->check(CLI::ExistingFile);
  app.add_option("--sensor", sensor_csv, "rtm watch --csv of the wrist sensor's out0")->required()->check(CLI::ExistingFile);
  app.add_option("--command", command_csv, "rtm watch --csv of the controller's out0")->required()->check(CLI::ExistingFile);
  app.add_option("--timing", timing_json, "output of `rtm --json ls -l`: loop timing and the components' statistics")
      ->check(CLI::ExistingFile);
  app.add_option("--out", out_dir, "folder for force_servo.csv, force_servo.gp, summary.txt")->required();
  app.add_option("--band", options.settle_band_N, "settling band, N")->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option("--steady-window", options.steady_window_s, "steady-state window at a phase's end, s")
      ->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option("--min-phase", options.min_duration_s, "shortest phase of constant reference, s")
      ->capture_default_str()->check(CLI::PositiveNumber);
  rtm::demo::FigureLimits limits;
  double max_overshoot_percent = limits.max_overshoot * 100;
  add_figure_options(app, options, limits, max_overshoot_percent);
  ScriptInputs script;
  add_script_options(app, script);
  app.add_flag("--check", check,
               "exit 3 when a figure is missed or not measured (see the summary's demo figures), a contact "
               "phase's steady-state error exceeds the band, or a component overran");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    return app.exit(error) == 0 ? 0 : 2;  // CLI11's own codes (105, 106, ...) are all "bad command line"
  }
  limits.max_overshoot = max_overshoot_percent / 100;
  script.limits.max_deviation_m = script.max_deviation_mm / 1000;

  try {
    const auto samples = rtm::demo::align(rtm::demo::read_watch_csv(reference_csv),
                                          rtm::demo::read_watch_csv(sensor_csv),
                                          rtm::demo::read_watch_csv(command_csv));
    if (samples.empty()) throw rtm::demo::ReportError("no sensor sample after the first reference sample");
    rtm::demo::Report report;
    report.samples = samples.size();
    report.duration_s = samples.back().time_s;
    const auto phases = rtm::demo::detect_phases(samples, options);
    for (const auto& phase : phases) report.phases.push_back(rtm::demo::summarize(samples, phase, options));
    report.figures = rtm::demo::compute_figures(samples, phases, options, limits);
    report.operator_figures = script.phases_csv.empty();
    if (!timing_json.empty()) {
      std::ifstream in(timing_json);
      const std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
      report.timing = rtm::demo::parse_timing_json(text, timing_json);
    }

    const std::filesystem::path dir(out_dir);
    std::filesystem::create_directories(dir);
    rtm::demo::write_samples_csv(dir / "force_servo.csv", samples);
    {
      std::ofstream gp(dir / "force_servo.gp");
      gp << rtm::demo::gnuplot_script(dir / "force_servo.csv", dir / "force_servo.png", report.phases);
      if (!gp.flush()) throw rtm::demo::ReportError((dir / "force_servo.gp").string() + ": write failed");
    }
    std::string summary = rtm::demo::format_report(report, options, limits);
    std::vector<std::string> script_missed;
    if (!script.phases_csv.empty()) summary += script_summary(script, sensor_csv, script_missed);
    {
      std::ofstream txt(dir / "summary.txt");
      txt << summary;
    }
    fmt::print("{}", summary);
    if (check) {
      auto missed = rtm::demo::missed_figures(report, options, limits);
      missed.insert(missed.end(), script_missed.begin(), script_missed.end());
      for (const auto& m : missed) fmt::print(stderr, "rtm-demo-report: missed: {}\n", m);
      if (!missed.empty()) return 3;
    }
  } catch (const std::exception& e) {
    fmt::print(stderr, "rtm-demo-report: {}\n", e.what());
    return 1;
  }
  return 0;
}
