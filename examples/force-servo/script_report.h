// SPDX-License-Identifier: Apache-2.0
// The force-servo demo's report on a motion script (docs/python.md, "Motion scripts"): what each
// of the script's motions did, and for each slide the force error along the normal and the path
// the tool followed. Input: the script's phase log (`rtm script --phases`), the wrist sensor's
// and the actuator's pose recordings (`rtm watch --csv`). No CORBA.
#pragma once

#include "demo_report.h"

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace rtm::demo {

// ============================ the phase log ===========================

// One motion of the script: a row of the phase log.
struct ScriptPhase {
  std::int64_t begin_ns = 0, end_ns = 0;      // CLOCK_REALTIME, as the recordings' stamps
  std::string motion;                         // approach, press, slide, ...
  std::string outcome;                        // done, stopped, error
  std::optional<double> force_N;              // the force it pressed with along the normal
  std::optional<std::array<double, 3>> normal;  // unit vector: the direction the tool presses in
  std::optional<std::array<double, 3>> along;   // unit vector: the direction it moved in
  std::string description;                    // "slide +x 50 mm at 10 mm/s at 10 N"
};

// Reads the log: the header "begin_ns,end_ns,motion,outcome,force_N,normal_x,normal_y,normal_z,
// along_x,along_y,along_z,description", then a row per motion (a vector's three cells empty
// when it has none; the description last, in double quotes). Throws ReportError naming the file
// and line for anything else.
std::vector<ScriptPhase> parse_script_phases(const std::string& text, const std::string& source_name);
std::vector<ScriptPhase> read_script_phases(const std::filesystem::path& path);

// ============================ a slide's figures =======================

struct SlideFigures {
  ScriptPhase phase;
  std::size_t force_samples = 0;
  // |force_N - the force applied along the normal| over the wrist samples inside the phase (the
  // applied force is the sensor's reading negated).
  double error_p50_N = 0, error_p99_N = 0, error_max_N = 0;
  double mean_applied_N = 0;
  // The path, from the pose samples inside the phase; none without any.
  std::size_t pose_samples = 0;
  std::optional<double> travelled_m;      // along `along`, first sample to last
  std::optional<double> deviation_p99_m;  // distance from the straight line through the first
  std::optional<double> deviation_max_m;  // sample along `along`
  std::array<double, 3> start_m{}, end_m{};  // first and last position
};

// The figures of a slide phase (its force and direction must be in the log: ReportError if
// not). `pose` may be empty.
SlideFigures slide_figures(const ScriptPhase& phase, const Series& sensor, const Series& pose);

struct ScriptLimits {
  double max_force_error_p99_N = 0.5;
  double max_deviation_m = 0.002;
};

// The summary's "Motion script" part: each motion (outcome, duration), then each slide's
// figures against the limits. `missed` receives one line per figure not kept (a slide's force
// error p99 or path deviation over its limit or not measured, a motion that did not end done).
std::string format_script_report(const std::vector<ScriptPhase>& phases, const std::vector<SlideFigures>& slides,
                                 const ScriptLimits& limits, std::vector<std::string>& missed);

}  // namespace rtm::demo
