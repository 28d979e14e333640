// The following-error check (CiA 402's following-error window, for cyclic synchronous velocity):
// a drive that moves other than it is told is stopped, whatever the cause (a spoofed command, a
// drive fault that reports nothing, a broken brake, an obstruction).
//
// For each drive, on each answer to a SYNC while the master commands it:
//   velocity error = actual velocity - the command acting since the previous SYNC
//   position error = actual position - (position at the anchor + the integral of the commands)
// Outside either window (MasterConfig::following_*) for more than following_error_periods
// answers in a row is a violation. The anchor is the first answer after rearm() and every answer
// at rest (commanded zero, slower than the rest velocity), so the integral cannot drift over a
// long run. Thread-free, no allocation.
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
  explicit FollowingErrorCheck(const MasterConfig& config);

  // The drive is not being commanded (enabling, quick stop, fault): its next answer re-anchors.
  void rearm(std::size_t joint) {
    anchored_[joint] = false;
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
  double velocity_window_;
  double position_window_;
  int periods_;
  double rest_velocity_;
  double period_s_;
  std::array<bool, kDriveCount> anchored_{};
  std::array<double, kDriveCount> demand_rad_{};
  std::array<int, kDriveCount> outside_{};
  double peak_velocity_ = 0;
  double peak_position_ = 0;
};

}  // namespace rtm::can
