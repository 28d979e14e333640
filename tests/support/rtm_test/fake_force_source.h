// SPDX-License-Identifier: Apache-2.0
// The one fake of the force-sensor component's source seam (components/sensor/force_source.h):
// the test sets the sample and the fault it answers.
#pragma once

#include "components/sensor/force_source.h"

#include <functional>

namespace rtm_test {

class FakeForceSource final : public rtm::comp::ForceSource {
 public:
  rtm::comp::ForceSample sample;
  rtm::comp::Fault why;                    // the fault it answers (none by default)
  std::function<void()> when_fault_asked;  // runs after fault() has taken its answer
  rtm::comp::ForceSample latest() const override { return sample; }
  rtm::comp::FaultKind fault_kind() const override { return why.kind; }
  rtm::comp::Fault fault() const override {
    rtm::comp::Fault answer = why;
    if (when_fault_asked) when_fault_asked();
    return answer;
  }
  // A new wrench (and, for the wrist, the joints it was read in).
  void push(const std::array<double, 6>& wrench_sensor) {
    sample.wrench_sensor = wrench_sensor;
    sample.valid = true;
    sample.q_valid = true;
    ++sample.sequence;
  }
};

}  // namespace rtm_test
