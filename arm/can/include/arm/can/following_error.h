// SPDX-License-Identifier: Apache-2.0
// The following-error check (CiA 402's velocity and following-error windows, for cyclic
// synchronous velocity): a drive that moves other than it is told is stopped, whatever the cause
// (a spoofed command, a drive fault that reports nothing, a released brake, an obstruction).
//
// For each drive, on each answer to a SYNC while the master commands it:
//   velocity error = actual velocity - the command acting since the previous SYNC
//   position error = how far the joint moved over the last N answers - the integral of the
//                    commands over them (N = following_position_periods; fewer just after
//                    rearm())
// Outside either window (MasterConfig::following_*) for more than following_error_periods
// answers in a row is a violation. Thread-free; fixed-size buffers, no allocation.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "arm/can/master_types.h"

namespace rtm::can {

struct FollowingViolation {
  std::size_t joint = 0;
  bool position = false;  // false: the velocity window
  double error = 0;       // rad/s or rad
  double window = 0;
  int answers = 0;        // in a row outside the window
};

class FollowingErrorCheck {
 public:
  static constexpr int kMaxPositionPeriods = 1000;

  explicit FollowingErrorCheck(const MasterConfig& config);

  // The drive is not being commanded (enabling, quick stop, fault): its history is forgotten.
  void rearm(std::size_t joint) {
    history_[joint].count = 0;
    outside_[joint] = 0;
  }
  void rearm_all() {
    for (std::size_t j = 0; j < kDriveCount; ++j) rearm(j);
  }

  // Drive `joint` answered a SYNC with position q and velocity v; `acting_rad_s` is the command
  // it followed over the period before. True (and `violation` filled) on a violation.
  bool check(std::size_t joint, double acting_rad_s, double q_rad, double v_rad_s, FollowingViolation& violation);

  double peak_velocity_error_rad_s() const { return peak_velocity_; }
  double peak_position_error_rad() const { return peak_position_; }

 private:
  // The last N values of (position - integral of commands since rearm): their difference over
  // the window is the position error.
  struct History {
    std::array<double, kMaxPositionPeriods + 1> offset{};
    int next = 0;   // where the next value goes
    int count = 0;  // values held (<= periods + 1)
    double demand_rad = 0;
  };

  double velocity_window_;
  double position_window_;
  int position_periods_;
  int periods_;
  double period_s_;
  std::array<History, kDriveCount> history_{};
  std::array<int, kDriveCount> outside_{};
  double peak_velocity_ = 0;
  double peak_position_ = 0;
};

}  // namespace rtm::can
