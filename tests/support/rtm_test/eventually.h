// SPDX-License-Identifier: Apache-2.0
// Waiting for something another thread or process does, without a timed assertion.
#pragma once

#include <chrono>
#include <thread>

namespace rtm_test {

// How long eventually() waits by default: a guard against a hang, not a timing check. Long
// enough for a sanitizer build on a busy 2-vCPU machine; a passing test never waits it out.
inline constexpr std::chrono::seconds kEventuallyBound{20};

// Polls condition every millisecond until it holds (true) or bound has passed (false). Tests
// only ever assert that the condition became true, so no figure of the machine's speed is
// built into a test. The condition is tested once more after the bound, so a slow last poll
// still counts.
template <class Condition>
bool eventually(Condition&& condition, std::chrono::steady_clock::duration bound = kEventuallyBound) {
  const auto give_up = std::chrono::steady_clock::now() + bound;
  while (!condition()) {
    if (std::chrono::steady_clock::now() > give_up) return condition();
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return true;
}

}  // namespace rtm_test
