// SPDX-License-Identifier: Apache-2.0
// The operator's hand on the joystick: a time series of wrenches (steps, ramps, holds).
//
// YAML format (documented with an example in sim/README.md and sim/profiles/):
//   segments:
//     - hold: 1.0                                   # s: keep the current wrench
//     - step: {force_N: [0, 0, -10]}                # jump to this wrench
//     - ramp: {duration_s: 2.0, force_N: [5, 0, -10], torque_Nm: [0, 0, 0.5]}
//   repeat: false                                   # optional: loop the whole list
// The wrench starts at zero. In step/ramp an omitted force_N or torque_Nm keeps its current
// value. The wrench is the force the operator applies to the handle, in the joystick frame
// (aligned with the arm's base frame). After the last segment the last wrench is held.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "sim/wrench.h"

namespace rtm::sim {

// A profile file or line that cannot be used; what() names the source, the place (segment
// index or line) and what is wrong.
class ProfileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class OperatorProfile {
 public:
  // One knot of the piecewise-linear wrench: the wrench reached at time_s; `ramp` says whether
  // the wrench moves linearly from the previous knot (true) or jumps at time_s (false).
  struct Knot {
    double time_s = 0;
    Wrench wrench;
    bool ramp = false;
  };

  static OperatorProfile from_file(const std::string& path);                // throws ProfileError
  static OperatorProfile from_yaml(const std::string& yaml_text,
                                   const std::string& source_name);        // throws ProfileError
  // Zero wrench for ever.
  OperatorProfile() = default;

  // The wrench at time t_s (s since the profile started). Allocates nothing.
  Wrench wrench_at(double t_s) const;

  double duration_s() const { return knots_.empty() ? 0.0 : knots_.back().time_s; }
  bool repeats() const { return repeat_; }
  const std::vector<Knot>& knots() const { return knots_; }

 private:
  std::vector<Knot> knots_;
  bool repeat_ = false;
};

// Parses one stdin command line "fx fy fz [tx ty tz]" (N, N·m). Returns true and fills
// `wrench` for a valid line, false for a blank or '#' comment line (wrench untouched); throws
// ProfileError naming the line for anything else.
bool parse_wrench_line(const std::string& line, Wrench& wrench);

}  // namespace rtm::sim
