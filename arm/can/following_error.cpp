// SPDX-License-Identifier: Apache-2.0
#include "arm/can/following_error.h"

#include <algorithm>
#include <cmath>

namespace rtm::can {

FollowingErrorCheck::FollowingErrorCheck(const MasterConfig& config)
    : velocity_window_(config.following_velocity_window_rad_s),
      position_window_(config.following_position_window_rad),
      position_periods_(std::clamp(config.following_position_periods, 1, kMaxPositionPeriods)),
      periods_(config.following_error_periods),
      period_s_(static_cast<double>(config.period_ns) * 1e-9) {}

bool FollowingErrorCheck::check(std::size_t joint, double acting_rad_s, double q_rad, double v_rad_s,
                                FollowingViolation& violation) {
  History& h = history_[joint];
  const int size = position_periods_ + 1;
  if (h.count == 0) {
    h.demand_rad = 0;
  } else {
    h.demand_rad += acting_rad_s * period_s_;
  }
  h.offset[static_cast<std::size_t>(h.next)] = q_rad - h.demand_rad;
  const int oldest = h.count < size ? (h.next - h.count + size) % size : (h.next + 1) % size;
  h.next = (h.next + 1) % size;
  h.count = std::min(h.count + 1, size);
  if (h.count == 1) return false;  // the first answer: nothing to compare the velocity with yet

  const double velocity_error = v_rad_s - acting_rad_s;
  const double position_error = q_rad - h.demand_rad - h.offset[static_cast<std::size_t>(oldest)];
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
