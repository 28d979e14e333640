// SPDX-License-Identifier: Apache-2.0
// The clocks of the project, in nanoseconds as std::int64_t (the one time type of public APIs):
//   monotonic_ns()  CLOCK_MONOTONIC: schedules, deadlines, timeouts
//   realtime_ns()   CLOCK_REALTIME: stamps compared across processes and machines (data
//                   samples, the moment a command left for the bus)
//   Clock           CLOCK_MONOTONIC as a value, for what measures a silence against a timeout (a node's
//                   heartbeat): monotonic_clock() in a program, a manual clock that the test moves in a test
//                   (tests/support: rtm_test::ManualClock), so a timeout is passed by a step instead of by
//                   sleeping through it. What waits for I/O or a deadline stays on monotonic_ns().
#pragma once

#include <time.h>

#include <cstdint>

namespace rtm {

inline constexpr std::int64_t kNsPerSecond = 1'000'000'000;

inline std::int64_t monotonic_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * kNsPerSecond + ts.tv_nsec;
}

inline std::int64_t realtime_ns() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * kNsPerSecond + ts.tv_nsec;
}

class Clock {
 public:
  virtual ~Clock() = default;
  virtual std::int64_t now_ns() const = 0;  // CLOCK_MONOTONIC's scale
};

// CLOCK_MONOTONIC itself; lives for the whole program.
const Clock& monotonic_clock();

// ns >= 0.
constexpr timespec to_timespec(std::int64_t ns) {
  return timespec{static_cast<time_t>(ns / kNsPerSecond), static_cast<long>(ns % kNsPerSecond)};
}

// Sleeps until CLOCK_MONOTONIC deadline_ns (clock_nanosleep, TIMER_ABSTIME; an interrupted sleep is resumed).
void sleep_until_ns(std::int64_t deadline_ns);

}  // namespace rtm
