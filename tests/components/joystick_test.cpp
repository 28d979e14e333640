// SPDX-License-Identifier: Apache-2.0
// The Joystick (reference generator) without CORBA: the operator's force passes unchanged
// (its frame is base-aligned), one datum per new reading, faults surface.
#include "components/joystick/joystick.h"

#include "component_test_support.h"

#include <gtest/gtest.h>

namespace {

using comp_test::cycle;
using comp_test::values;

class FakeJoystickSource final : public rtm::comp::JoystickSource {
 public:
  rtm::comp::JoystickReading reading;
  std::string why;
  rtm::comp::JoystickReading latest() const override { return reading; }
  std::string fault() const override { return why; }
};

struct JoystickUnderTest {
  FakeJoystickSource* source = nullptr;
  std::unique_ptr<rtm::comp::Joystick> joystick;
  JoystickUnderTest() {
    auto fake = std::make_unique<FakeJoystickSource>();
    source = fake.get();
    joystick = std::make_unique<rtm::comp::Joystick>("joystick0", std::move(fake));
  }
  void push(std::array<double, 6> w) {
    source->reading = {w, source->reading.sequence + 1, true};
  }
};

TEST(Joystick, OperatorPushingDownIsADownwardReferenceUnchanged) {
  JoystickUnderTest t;
  t.joystick->on_start();
  t.push({0.5, -1.5, -10, 0.1, 0, -0.2});
  t.joystick->on_cycle(cycle(0));
  RTM::TimedFloat6 out{};
  ASSERT_TRUE(t.joystick->out().latest(out));
  const std::array<float, 6> expected{0.5f, -1.5f, -10.0f, 0.1f, 0.0f, -0.2f};
  EXPECT_EQ(values(out), expected);
}

TEST(Joystick, WritesOnlyNewReadings) {
  JoystickUnderTest t;
  t.joystick->on_start();
  t.joystick->on_cycle(cycle(0));
  EXPECT_EQ(t.joystick->samples_written(), 0u) << "nothing read yet";
  t.push({1, 0, 0, 0, 0, 0});
  t.joystick->on_cycle(cycle(1));
  t.joystick->on_cycle(cycle(2));
  EXPECT_EQ(t.joystick->samples_written(), 1u);
  t.push({2, 0, 0, 0, 0, 0});
  t.joystick->on_cycle(cycle(3));
  EXPECT_EQ(t.joystick->samples_written(), 2u);
}

TEST(Joystick, SourceFaultThrowsTheReason) {
  JoystickUnderTest t;
  t.joystick->on_start();
  t.source->why = "joystick sensor 0x11: EMCY 0x7300";
  EXPECT_THROW(t.joystick->on_cycle(cycle(0)), std::runtime_error);
}

}  // namespace
