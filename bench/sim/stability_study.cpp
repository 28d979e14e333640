// SPDX-License-Identifier: Apache-2.0
// What the loop's latency costs a force loop: for each surface and each sample-to-drive delay,
// the largest gain of the paper's P controller that keeps the contact loop stable, and the
// settling time it gives. Lock-step simulation of the PA10 stand-in (sim/pa10_plant.h): no
// processes, no bus; the bus's timing is modelled where it acts (docs/pa10-model.md, "What the
// loop's latency buys").
//
// Per run: the tool descends at 5 mm/s until it presses with 0.5 N, then the controller takes
// over, v_z = -gain * (10 N - pressing force) (the paper's gain * (reference + sensor), the
// reference being -10 N), clamped to the actuator's 0.05 m/s, and turned into joint rates by the
// arm library's velocity IK once per 2 ms cycle. The command computed from the wrench measured
// at SYNC k is latched by the drives at SYNC k + delay: delay 1 is the shared tick (the sample
// is read and the command leaves within the same period, 30 µs apart), delay 2 the paper's
// separate processes at their median (1.5-2.6 ms from read to bus, plus the sample's age),
// delay 3 the same at their worst. A gain is stable when the force overshoots 10 N by at most
// 20 % and does not oscillate (it swings by at most 1 N over the last second of a 5 s run); the
// settling time is the last time it was outside ±0.5 N of 10 N (5 s: not settled in the run).
//
//   stability_study [--bandwidth RAD_S] [--model SCENE] [--csv FILE] [--runs FILE]
//   gnuplot -e "csv='FILE'; png='study.png'" bench/sim/stability_study.gp   (the plot)
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include "arm/pa10/kinematics.h"
#include "sim/pa10_plant.h"
#include "sim/surface.h"

namespace {

using rtm::sim::JointCommand;
using rtm::sim::Pa10Plant;
using rtm::sim::ServoGains;
using rtm::sim::Surface;
using rtm::sim::kJointCount;

constexpr double kCycle_s = 0.002;
constexpr double kTarget_N = 10;
constexpr double kBand_N = 0.5;
constexpr double kLimit_m_s = 0.05;
constexpr double kRun_s = 5;
// Slow enough that the touch-down itself (the commands still in flight when the tool meets the
// surface) does not overshoot on steel: the study is about the loop, not the impact.
constexpr double kApproach_m_s = 0.005;

struct Outcome {
  bool touched = false;
  double peak_N = 0;
  double settling_s = 0;     // after touch-down; kRun_s if never settled
  double late_min_N = 1e9, late_max_N = -1e9;  // over the last second
  // No overshoot beyond 20 % and no sustained oscillation (a swing of more than the band's
  // width over the last second); a loop still creeping up slowly is stable, only slow.
  bool stable() const {
    return touched && peak_N <= kTarget_N * 1.2 && late_max_N - late_min_N <= 2 * kBand_N;
  }
};

class Loop {
 public:
  Loop(const std::string& scene, const Surface& surface, double bandwidth_rad_s)
      : plant_(scene, gains(bandwidth_rad_s), surface),
        kinematics_(rtm::pa10::Kinematics::pa10()),
        ik_(kinematics_),
        steps_per_cycle_(static_cast<int>(std::lround(kCycle_s / plant_.timestep_s()))),
        weight_N_(plant_.wrist_wrench().force_N[2]) {}

  // One 2 ms cycle: the drives follow a tool velocity v_z (base frame), then the force is read.
  double cycle(double vz_m_s) {
    rtm::pa10::JointVector q;
    for (int j = 0; j < kJointCount; ++j) q[j] = plant_.joint_state(j).position_rad;
    rtm::pa10::Twist twist = rtm::pa10::Twist::Zero();
    twist[2] = vz_m_s;
    const auto solution = ik_.solve(twist, q, kCycle_s);
    for (int j = 0; j < kJointCount; ++j)
      plant_.set_command(j, {JointCommand::Mode::velocity, solution.qdot_rad_s[j]});
    for (int i = 0; i < steps_per_cycle_; ++i) plant_.step();
    // The table pushes the tool back along -z of the sensor frame (tool pointing down).
    return -(plant_.wrist_wrench().force_N[2] - weight_N_);
  }

 private:
  static ServoGains gains(double bandwidth_rad_s) {
    ServoGains g;
    g.velocity_bandwidth_rad_s = bandwidth_rad_s;
    return g;
  }

  Pa10Plant plant_;
  rtm::pa10::Kinematics kinematics_;
  rtm::pa10::VelocityIk ik_;
  int steps_per_cycle_;
  double weight_N_;
};

struct Settings {
  std::string scene = RTM_PA10_SCENE;
  double bandwidth_rad_s = ServoGains{}.velocity_bandwidth_rad_s;
};

Outcome run(const Settings& settings, const Surface& surface, double gain, int delay_cycles) {
  Loop loop(settings.scene, surface, settings.bandwidth_rad_s);
  Outcome outcome;
  double force_N = 0;
  for (int i = 0; i < 20000 && force_N < 0.5; ++i) force_N = loop.cycle(-kApproach_m_s);
  if (force_N < 0.5) return outcome;
  outcome.touched = true;
  // Commands in flight: the one computed at SYNC k acts from SYNC k + delay on.
  std::deque<double> in_flight(static_cast<std::size_t>(delay_cycles - 1), -kApproach_m_s);
  const int cycles = static_cast<int>(kRun_s / kCycle_s);
  const int late_from = static_cast<int>((kRun_s - 1) / kCycle_s);
  for (int k = 0; k < cycles; ++k) {
    in_flight.push_back(std::clamp(-gain * (kTarget_N - force_N), -kLimit_m_s, kLimit_m_s));
    const double vz = in_flight.front();
    in_flight.pop_front();
    force_N = loop.cycle(vz);
    if (!std::isfinite(force_N)) return outcome;
    outcome.peak_N = std::max(outcome.peak_N, force_N);
    const double error_N = std::abs(force_N - kTarget_N);
    if (error_N > kBand_N) outcome.settling_s = (k + 1) * kCycle_s;
    if (k >= late_from) {
      outcome.late_min_N = std::min(outcome.late_min_N, force_N);
      outcome.late_max_N = std::max(outcome.late_max_N, force_N);
    }
  }
  return outcome;
}

struct Point {
  const char* mode;
  int delay_cycles;
  Surface surface;
  double gain = 0;  // largest stable; 0 if none in the sweep
  Outcome outcome;
};

// Gains from 1e-5 up by 10 % steps while stable; the largest stable one and its outcome.
Point largest_stable_gain(const char* mode, int delay, const Surface& surface, const Settings& settings,
                          std::FILE* runs) {
  Point point{mode, delay, surface, 0, {}};
  for (double gain = 1e-5; gain < 1; gain *= 1.1) {
    const Outcome o = run(settings, surface, gain, delay);
    if (runs)
      std::fprintf(runs, "%s,%d,%s,%.0f,%.6g,%d,%.3f,%.3f,%.3f\n", mode, delay, surface.name.c_str(),
                   surface.stiffness_N_m, gain, o.stable() ? 1 : 0, o.peak_N, o.settling_s,
                   o.late_max_N - o.late_min_N);
    if (!o.stable() && point.gain > 0) break;  // past the stability limit
    if (o.stable()) {
      point.gain = gain;
      point.outcome = o;
    }
  }
  return point;
}

}  // namespace

int main(int argc, char** argv) {
  Settings settings;
  std::string csv_path;
  std::string runs_path;
  CLI::App app{"The largest stable force gain per surface and sample-to-drive delay (lock-step)"};
  app.add_option("--bandwidth", settings.bandwidth_rad_s, "drive velocity bandwidth [rad/s]")
      ->check(CLI::Range(1e-3, 500.0))
      ->capture_default_str();
  app.add_option("--model", settings.scene, "MuJoCo scene")->capture_default_str();
  app.add_option("--csv", csv_path, "write the table as CSV (surface, mode, gain, peak, settling)");
  app.add_option("--runs", runs_path, "write every run as CSV (each gain tried)");
  CLI11_PARSE(app, argc, argv);
  const double bandwidth = settings.bandwidth_rad_s;
  try {
    Pa10Plant check(settings.scene);  // a scene that does not load fails here, with its reason
  } catch (const std::exception& error) {
    std::fprintf(stderr, "%s: %s\n", argv[0], error.what());
    return 1;
  }
  std::FILE* runs = runs_path.empty() ? nullptr : std::fopen(runs_path.c_str(), "w");
  if (runs) std::fprintf(runs, "mode,delay_cycles,surface,stiffness_N_m,gain,stable,peak_N,settling_s,late_swing_N\n");
  if (!runs_path.empty() && !runs) {
    std::fprintf(stderr, "%s: cannot write %s\n", argv[0], runs_path.c_str());
    return 1;
  }
  struct Mode {
    const char* name;
    int delay;
  };
  const Mode modes[] = {{"shared tick", 1}, {"paper median", 2}, {"paper worst", 3}};
  std::vector<Point> points;
  for (const Surface& surface : rtm::sim::surface_presets())
    for (const Mode& mode : modes) points.push_back(largest_stable_gain(mode.name, mode.delay, surface, settings, runs));
  if (runs) std::fclose(runs);

  std::printf("%s\n", settings.scene.c_str());
  std::printf("drive velocity bandwidth %.0f rad/s; reference 10 N from touch-down; stable: overshoot "
              "<= 20 %%, swing <= 1 N over the last of 5 s\n\n",
              bandwidth);
  std::printf("| surface | N/m | mode | delay | largest stable gain [m/(s·N)] | overshoot | settling [s] |\n");
  std::printf("| --- | ---: | --- | ---: | ---: | ---: | ---: |\n");
  for (const Point& p : points) {
    if (p.gain == 0) {
      std::printf("| %s | %.0f | %s | %d | none found | | |\n", p.surface.name.c_str(), p.surface.stiffness_N_m,
                  p.mode, p.delay_cycles);
      continue;
    }
    std::printf("| %s | %.0f | %s | %d | %.3g | %.0f %% | %.3f |\n", p.surface.name.c_str(),
                p.surface.stiffness_N_m, p.mode, p.delay_cycles, p.gain,
                std::max(0.0, (p.outcome.peak_N - kTarget_N) / kTarget_N * 100), p.outcome.settling_s);
  }
  if (!csv_path.empty()) {
    std::FILE* csv = std::fopen(csv_path.c_str(), "w");
    if (!csv) {
      std::fprintf(stderr, "%s: cannot write %s\n", argv[0], csv_path.c_str());
      return 1;
    }
    std::fprintf(csv, "surface,stiffness_N_m,mode,delay_cycles,gain,peak_N,settling_s\n");
    for (const Point& p : points)
      std::fprintf(csv, "%s,%.0f,%s,%d,%.6g,%.3f,%.3f\n", p.surface.name.c_str(), p.surface.stiffness_N_m,
                   p.mode, p.delay_cycles, p.gain, p.outcome.peak_N, p.outcome.settling_s);
    std::fclose(csv);
  }
  return 0;
}
