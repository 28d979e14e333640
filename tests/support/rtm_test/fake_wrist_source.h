// SPDX-License-Identifier: Apache-2.0
// The one fake of the Sensor component's source seam (components/sensor/wrist_source.h): the
// test sets the sample and the fault it answers.
#pragma once

#include "components/sensor/wrist_source.h"

#include <functional>

namespace rtm_test {

class FakeWristSource final : public rtm::comp::WristSampleSource {
 public:
  rtm::comp::WristSample sample;
  rtm::comp::Fault why;                    // the fault it answers (none by default)
  std::function<void()> when_fault_asked;  // runs after fault() has taken its answer
  rtm::comp::WristSample latest() const override { return sample; }
  rtm::comp::FaultKind fault_kind() const override { return why.kind; }
  rtm::comp::Fault fault() const override {
    rtm::comp::Fault answer = why;
    if (when_fault_asked) when_fault_asked();
    return answer;
  }
};

}  // namespace rtm_test
