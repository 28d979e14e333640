// SPDX-License-Identifier: Apache-2.0
#include "rt/clock.h"

#include <cerrno>

namespace rtm {

namespace {

class MonotonicClock final : public Clock {
 public:
  std::int64_t now_ns() const override { return monotonic_ns(); }
};

}  // namespace

const Clock& monotonic_clock() {
  static const MonotonicClock clock;
  return clock;
}

void sleep_until_ns(std::int64_t deadline_ns) {
  const timespec ts = to_timespec(deadline_ns);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

}  // namespace rtm
