// SPDX-License-Identifier: Apache-2.0
// How fresh a periodic input is: the age, in cycles, of its newest datum.
//
// A component that reads an input each cycle calls tick() once per cycle, saying whether a new datum came.
// The input is fresh from its first datum until `limit` cycles pass without another; tick() reports the cycle
// it goes stale, once per event, so a caller can count and log each event without repeating itself. The
// controller's "stale input" and the actuator's watchdog are both this.
#pragma once

#include <cstdint>

namespace rtm {

class Freshness {
 public:
  // limit_cycles >= 1: cycles without a new datum after which the input is stale.
  explicit Freshness(std::uint32_t limit_cycles) : limit_(limit_cycles) {}

  enum class Change { none, went_stale };

  // One cycle: new_datum resets the age to 0, otherwise it grows (saturating at the limit).
  Change tick(bool new_datum) {
    const bool was_fresh = fresh();
    if (new_datum) {
      age_ = 0;
      seen_ = true;
    } else if (age_ < limit_) {
      ++age_;
    }
    return was_fresh && !fresh() ? Change::went_stale : Change::none;
  }

  bool fresh() const { return seen_ && age_ < limit_; }
  bool seen() const { return seen_; }  // a datum came since construction or reset()
  std::uint32_t age() const { return age_; }
  std::uint32_t limit() const { return limit_; }
  // As new: nothing seen (not fresh), age 0.
  void reset() {
    age_ = 0;
    seen_ = false;
  }

 private:
  std::uint32_t limit_;
  std::uint32_t age_ = 0;
  bool seen_ = false;
};

}  // namespace rtm
