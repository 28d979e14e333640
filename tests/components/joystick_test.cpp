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
  std::string why;       // "" when healthy
  bool silent = false;  // the fault is a heartbeat loss (else the sensor's own EMCY)
  rtm::comp::JoystickReading latest() const override { return reading; }
  rtm::can::FaultKind fault_kind() const override {
    if (why.empty()) return rtm::can::FaultKind::none;
    return silent ? rtm::can::FaultKind::heartbeat_lost : rtm::can::FaultKind::emergency;
  }
  rtm::can::Fault fault() const override { return {fault_kind(), 0x11, 0, why}; }
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
  EXPECT_EQ(t.joystick->counters().samples, 0u) << "nothing read yet";
  t.push({1, 0, 0, 0, 0, 0});
  t.joystick->on_cycle(cycle(1));
  t.joystick->on_cycle(cycle(2));
  EXPECT_EQ(t.joystick->counters().samples, 1u);
  t.push({2, 0, 0, 0, 0, 0});
  t.joystick->on_cycle(cycle(3));
  EXPECT_EQ(t.joystick->counters().samples, 2u);
}

TEST(Joystick, SourceFaultThrowsTheReason) {
  JoystickUnderTest t;
  t.joystick->on_start();
  t.source->why = "joystick sensor 0x11: EMCY 0x7300";
  EXPECT_THROW(t.joystick->on_cycle(cycle(0)), std::runtime_error);
}

// A silent joystick node (the simulator's process stalled) is waited out: nothing is written
// meanwhile, not even a wrench read before the loss; heard again with a newer one, the
// joystick writes again, the loss and the recovery counted once each.
TEST(Joystick, AHeartbeatGapIsWaitedOutAndTheJoystickWritesAgainWhenHeard) {
  JoystickUnderTest t;
  t.joystick->on_start();
  t.push({1, 0, 0, 0, 0, 0});
  t.joystick->on_cycle(cycle(0));
  ASSERT_EQ(t.joystick->counters().samples, 1u);
  t.source->why = "joystick sensor 0x11: no heartbeat for 301 ms";
  t.source->silent = true;
  for (int i = 1; i < 50; ++i) EXPECT_NO_THROW(t.joystick->on_cycle(cycle(i))) << i;
  EXPECT_EQ(t.joystick->counters().heartbeat_losses, 1u);
  t.source->why.clear();
  t.source->silent = false;
  t.joystick->on_cycle(cycle(50));
  EXPECT_EQ(t.joystick->counters().samples, 1u) << "heard again, but no new wrench yet";
  t.push({-2, 0, 0, 0, 0, 0});
  t.joystick->on_cycle(cycle(51));
  EXPECT_EQ(t.joystick->counters().samples, 2u);
  EXPECT_EQ(t.joystick->counters().heartbeat_recoveries, 1u);
  RTM::TimedFloat6 out{};
  ASSERT_TRUE(t.joystick->out().latest(out));
  EXPECT_EQ(out.val[0], -2.0f);
}

TEST(Joystick, AHeartbeatGapLongerThanTheBudgetIsAnError) {
  JoystickUnderTest t;
  t.joystick->on_start();
  t.source->why = "joystick sensor 0x11: no heartbeat for 301 ms";
  t.source->silent = true;
  std::uint64_t n = 0;
  for (; n < rtm::comp::Joystick::kHeartbeatRecoveryPeriods; ++n)
    ASSERT_NO_THROW(t.joystick->on_cycle(cycle(n))) << n;
  try {
    t.joystick->on_cycle(cycle(n));
    FAIL() << "no error after the budget";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("not heard again"), std::string::npos) << e.what();
  }
  // Another fault while the node is silent-then-back is no stall: thrown at once.
  JoystickUnderTest other;
  other.joystick->on_start();
  other.source->why = "joystick sensor 0x11: no heartbeat for 301 ms";
  other.source->silent = true;
  other.joystick->on_cycle(cycle(0));
  other.source->why = "joystick sensor 0x11: EMCY 0x7300";
  other.source->silent = false;
  EXPECT_THROW(other.joystick->on_cycle(cycle(1)), std::runtime_error);
}

}  // namespace
