// SPDX-License-Identifier: Apache-2.0
// A clock that moves only when the test says (rt/clock.h): what measures a silence against a
// timeout on it sees the timeout pass in one advance(), however slow the machine, and never
// while the test does not move it.
#pragma once

#include "rt/clock.h"

#include <atomic>
#include <cstdint>

namespace rtm_test {

class ManualClock final : public rtm::Clock {
 public:
  // Starts at CLOCK_MONOTONIC's now, so its times are of the same scale as the bus's stamps.
  ManualClock() : now_ns_(rtm::monotonic_ns()) {}
  std::int64_t now_ns() const override { return now_ns_.load(); }
  void advance(std::int64_t ns) { now_ns_.fetch_add(ns); }

 private:
  std::atomic<std::int64_t> now_ns_;
};

}  // namespace rtm_test
