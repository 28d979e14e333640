// SPDX-License-Identifier: Apache-2.0
// One force sensor's wrench for one SYNC, put together from its two halves: TPDO1 (force) and
// TPDO2 (torque) answer the same SYNC and may arrive in either order. The one place that does
// it, for the master's cycle (bus_cycle.h) and the passive listener (sensor_listener.h).
#pragma once

#include <array>
#include <cstddef>

namespace rtm::can {

class WrenchAssembly {
 public:
  // A new SYNC: whatever was gathered is dropped. True when exactly one half was there (its
  // partner never came: a late or lost frame).
  bool restart() {
    const bool half = has_force_ != has_torque_;
    has_force_ = has_torque_ = withheld_ = false;
    return half;
  }
  // A half arrived. True when that half had arrived already for this SYNC: a late answer to an
  // older SYNC, or another sender using the sensor's id. Which is genuine is unknown, so the
  // wrench of this SYNC is withheld from then on (never complete()).
  bool add_force(const std::array<double, 3>& force_N) { return add(force_N, 0, has_force_); }
  bool add_torque(const std::array<double, 3>& torque_Nm) { return add(torque_Nm, 3, has_torque_); }

  // Another sender used the sensor's id in this SYNC's window: its wrench is withheld too.
  void withhold() { withheld_ = true; }

  bool complete() const { return has_force_ && has_torque_ && !withheld_; }
  // Both halves came (complete, or withheld because one came twice): nothing more to wait for.
  bool answered() const { return has_force_ && has_torque_; }
  // Fx Fy Fz [N], Tx Ty Tz [N·m]; the wrench once complete().
  const std::array<double, 6>& values() const { return values_; }

 private:
  bool add(const std::array<double, 3>& half, std::size_t offset, bool& has) {
    const bool again = has;
    if (again) withheld_ = true;
    else
      for (std::size_t i = 0; i < 3; ++i) values_[offset + i] = half[i];
    has = true;
    return again;
  }

  std::array<double, 6> values_{};
  bool has_force_ = false;
  bool has_torque_ = false;
  bool withheld_ = false;
};

}  // namespace rtm::can
