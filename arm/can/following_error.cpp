#include "arm/can/following_error.h"

#include <algorithm>
#include <cmath>

namespace rtm::can {

FollowingErrorCheck::FollowingErrorCheck(const MasterConfig& config)
    : velocity_window_(config.following_velocity_window_rad_s),
      position_window_(config.following_position_window_rad),
      periods_(config.following_error_periods),
      rest_velocity_(config.following_rest_velocity_rad_s),
      period_s_(static_cast<double>(config.period_ns) * 1e-9) {}

bool FollowingErrorCheck::check(std::size_t joint, double acting_rad_s, double q_rad, double v_rad_s,
                                FollowingViolation& violation) {
  const bool at_rest = acting_rad_s == 0.0 && std::abs(v_rad_s) < rest_velocity_;
  if (!anchored_[joint] || at_rest) {
    anchored_[joint] = true;
    demand_rad_[joint] = q_rad;
    outside_[joint] = 0;
    return false;
  }
  demand_rad_[joint] += acting_rad_s * period_s_;
  const double velocity_error = v_rad_s - acting_rad_s;
  const double position_error = q_rad - demand_rad_[joint];
  peak_velocity_ = std::max(peak_velocity_, std::abs(velocity_error));
  peak_position_ = std::max(peak_position_, std::abs(position_error));
  const bool velocity_outside = velocity_window_ > 0 && std::abs(velocity_error) > velocity_window_;
  const bool position_outside = position_window_ > 0 && std::abs(position_error) > position_window_;
  if (!velocity_outside && !position_outside) {
    outside_[joint] = 0;
    return false;
  }
  if (++outside_[joint] <= periods_) return false;
  violation.joint = joint;
  violation.position = !velocity_outside;
  violation.error = velocity_outside ? velocity_error : position_error;
  violation.window = velocity_outside ? velocity_window_ : position_window_;
  violation.answers = outside_[joint];
  return true;
}

}  // namespace rtm::can
