// SPDX-License-Identifier: Apache-2.0
// The clocks of the project, in nanoseconds as std::int64_t (the one time type of public APIs):
//   monotonic_ns()  CLOCK_MONOTONIC: schedules, deadlines, timeouts
//   realtime_ns()   CLOCK_REALTIME: stamps compared across processes and machines (data
//                   samples, the moment a command left for the bus)
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

// ns >= 0.
constexpr timespec to_timespec(std::int64_t ns) {
  return timespec{static_cast<time_t>(ns / kNsPerSecond), static_cast<long>(ns % kNsPerSecond)};
}

// Sleeps until the CLOCK_MONOTONIC time deadline_ns (clock_nanosleep, TIMER_ABSTIME; an
// interrupted sleep is resumed).
void sleep_until_ns(std::int64_t deadline_ns);

}  // namespace rtm
