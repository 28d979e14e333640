// SPDX-License-Identifier: Apache-2.0
// The Controller without CORBA: Fig. 6's arithmetic, stale and non-finite inputs give a zero
// command (never the last one), the command carries the sensor sample's stamp.
#include "components/controller/controller.h"

#include "component_test_support.h"

#include <gtest/gtest.h>

#include <cmath>

#include <limits>
#include <optional>

namespace {

using comp_test::cycle;
using comp_test::parameter;
using comp_test::statistic;
using comp_test::float6;
using comp_test::values;

constexpr std::array<float, 6> kZero{};
// What a cycle wrote: its command, or nothing (withheld: the actuator's watchdog brakes).
using Written = std::optional<std::array<float, 6>>;
constexpr std::nullopt_t kWithheld = std::nullopt;

struct ControllerUnderTest {
  rtm::comp::Controller controller;
  std::uint64_t n = 0;
  explicit ControllerUnderTest(rtm::comp::ControllerParams params = gains({0.5f, 1, 2, 0.1f, 0.2f, 0.3f}))
      : controller("controller0", params) {
    controller.on_start();
  }
  static rtm::comp::ControllerParams gains(std::array<float, 6> g) {
    rtm::comp::ControllerParams p;
    p.gain = g;
    p.approach_speed_m_s = 0;  // the paper's P, contact or not
    return p;
  }
  Written step() {
    const std::uint64_t before = controller.command_out().counters_snapshot().written;
    controller.on_cycle(cycle(n++));
    if (controller.command_out().counters_snapshot().written == before) return kWithheld;
    RTM::TimedFloat6 out{};
    EXPECT_TRUE(controller.command_out().latest(out));
    return values(out);
  }
  RTM::TimedFloat6 last() {
    RTM::TimedFloat6 out{};
    controller.command_out().latest(out);
    return out;
  }
};

TEST(ControllerLaw, OutputIsGainTimesReferencePlusSensor) {
  const RTM::TimedFloat6 ref = float6({1, 2, 3, 4, 5, 6});
  const RTM::TimedFloat6 sen = float6({0.5f, -4, 1, 0, -5, 2});
  const auto out = rtm::comp::proportional_command({2, 3, 0.5f, 1, 10, -1}, ref.val, sen.val);
  const std::array<float, 6> expected{3.0f, -6.0f, 2.0f, 4.0f, 0.0f, -8.0f};
  EXPECT_EQ(out, expected);
}

TEST(Controller, PressingReferenceBalancedByTheReactionGivesZero) {
  ControllerUnderTest t(ControllerUnderTest::gains({0.003f, 0.003f, 0.003f, 0, 0, 0}));
  t.controller.reference_in().deliver(float6({0, 0, -10, 0, 0, 0}));
  t.controller.sensor_in().deliver(float6({0, 0, 10, 0, 0, 0}));
  EXPECT_EQ(t.step(), kZero);
}

TEST(Controller, FreeSpaceCommandPointsWhereTheOperatorPushes) {
  ControllerUnderTest t(ControllerUnderTest::gains({0.003f, 0.003f, 0.003f, 0, 0, 0}));
  t.controller.reference_in().deliver(float6({5, 0, -10, 0, 0, 0}));
  t.controller.sensor_in().deliver(float6({0, 0, 0, 0, 0, 0}));
  const auto v = t.step().value();
  EXPECT_FLOAT_EQ(v[0], 0.015f);
  EXPECT_FLOAT_EQ(v[2], -0.03f);
}

// The bounded touch-down: contact gain 0.001, free-space gain 0.01, approach speed 5 mm/s,
// contact from 1 N.
rtm::comp::ControllerParams guarded() {
  rtm::comp::ControllerParams p;
  p.gain = {0.001f, 0.001f, 0.001f, 0, 0, 0};
  p.free_gain = {0.01f, 0.01f, 0.01f, 0.1f, 0, 0};
  p.approach_speed_m_s = 0.005f;
  p.contact_force_N = 1.0f;
  return p;
}

TEST(Controller, InFreeSpaceTheFreeGainIsSlowedToTheApproachSpeedWithItsDirectionKept) {
  ControllerUnderTest t(guarded());
  t.controller.reference_in().deliver(float6({3, 0, -4, 1, 0, 0}));
  t.controller.sensor_in().deliver(float6({0, 0, 0.5f, 0, 0, 0}));  // below 1 N: free space
  const auto v = t.step().value();
  // free_gain * (ref + sen) = (0.03, 0, -0.035), 46 mm/s, scaled to 5 mm/s.
  const float speed = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  EXPECT_NEAR(speed, 0.005f, 1e-6f);
  EXPECT_NEAR(v[0] / v[2], 0.03f / -0.035f, 1e-5f) << "direction kept";
  EXPECT_FLOAT_EQ(v[3], 0.1f) << "rotations take the free gain, not the speed limit";
  EXPECT_EQ(t.controller.counters().approach_limited, 1u);
  // A push slower than the limit is left alone.
  t.controller.reference_in().deliver(float6({0.2f, 0, 0, 0, 0, 0}));
  t.controller.sensor_in().deliver(float6({0, 0, 0, 0, 0, 0}));
  EXPECT_FLOAT_EQ(t.step().value()[0], 0.002f);
  EXPECT_EQ(t.controller.counters().approach_limited, 1u);
}

TEST(Controller, FromTheContactForceOnTheContactGainActsAndTouchDownsAreCounted) {
  ControllerUnderTest t(guarded());
  t.controller.reference_in().deliver(float6({0, 0, -10, 0, 0, 0}));
  t.controller.sensor_in().deliver(float6({0, 0, 1.0f, 0, 0, 0}));  // reaches 1 N
  EXPECT_FLOAT_EQ(t.step().value()[2], 0.001f * -9.0f) << "the paper's P with the contact gain";
  EXPECT_EQ(t.controller.counters().touch_downs, 1u);
  EXPECT_EQ(t.controller.counters().approach_limited, 0u);
}

TEST(Controller, ContactIsLeftOnlyAfterTenCyclesBelowHalfTheContactForce) {
  rtm::comp::ContactDetector contact;
  EXPECT_FALSE(contact.update(float6({0, 0.9f, 0, 0, 0, 0}).val, 1.0f));
  EXPECT_TRUE(contact.update(float6({0.6f, 0.8f, 0, 0, 0, 0}).val, 1.0f)) << "|F| = 1 N";
  EXPECT_TRUE(contact.update(float6({0, 0, 0.6f, 0, 0, 0}).val, 1.0f)) << "above half: still touching";
  for (std::uint32_t i = 1; i < rtm::comp::ContactDetector::kLiftOffCycles; ++i)
    EXPECT_TRUE(contact.update(float6({0, 0, 0.4f, 0, 0, 0}).val, 1.0f)) << "a bounce, cycle " << i;
  EXPECT_TRUE(contact.update(float6({0, 0, 0.7f, 0, 0, 0}).val, 1.0f)) << "back above half: the count restarts";
  for (std::uint32_t i = 1; i < rtm::comp::ContactDetector::kLiftOffCycles; ++i)
    ASSERT_TRUE(contact.update(float6({0, 0, 0.1f, 0, 0, 0}).val, 1.0f));
  EXPECT_FALSE(contact.update(float6({0, 0, 0.1f, 0, 0, 0}).val, 1.0f)) << "lifted off after 10 cycles below";
}

TEST(Controller, ABouncingTouchDownCountsOneTouchDownAndNoLiftOff) {
  ControllerUnderTest t(guarded());
  const float forces[] = {0, 3, 8, 0.2f, 0.1f, 6, 10, 10};
  for (float f : forces) {
    t.controller.reference_in().deliver(float6({0, 0, -10, 0, 0, 0}));
    t.controller.sensor_in().deliver(float6({0, 0, f, 0, 0, 0}));
    ASSERT_TRUE(t.step().has_value());
  }
  EXPECT_EQ(t.controller.counters().touch_downs, 1u);
  EXPECT_EQ(t.controller.counters().lift_offs, 0u);
}

TEST(Controller, ANegativeApproachSpeedOrAContactForceNotAboveZeroIsRefusedNamingIt) {
  rtm::comp::ControllerParams p = guarded();
  p.approach_speed_m_s = -0.001f;
  try {
    p.validate();
    FAIL() << "a negative approach speed was accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("approach_speed"), std::string::npos) << error.what();
  }
  p = guarded();
  p.contact_force_N = 0;
  EXPECT_THROW(p.validate(), std::invalid_argument);
  ControllerUnderTest t(guarded());
  EXPECT_THROW(parameter(t.controller, "approach_speed").set("-1"), std::invalid_argument);
  EXPECT_THROW(parameter(t.controller, "contact_force").set("0"), std::invalid_argument);
  EXPECT_EQ(parameter(t.controller, "approach_speed").get(), "0.005");
  parameter(t.controller, "approach_speed").set("0");
  EXPECT_EQ(t.controller.params().approach_speed_m_s, 0.0f);
}

TEST(Controller, ApproachSpeedZeroSetWhileRunningIsThePapersPlainPFromTheNextCycle) {
  ControllerUnderTest t(guarded());
  t.controller.reference_in().deliver(float6({0, 0, -10, 0, 0, 0}));
  t.controller.sensor_in().deliver(float6({0, 0, 0, 0, 0, 0}));
  EXPECT_NEAR(t.step().value()[2], -0.005f, 1e-7f);
  parameter(t.controller, "approach_speed").set("0");
  t.controller.reference_in().deliver(float6({0, 0, -10, 0, 0, 0}));
  t.controller.sensor_in().deliver(float6({0, 0, 0, 0, 0, 0}));
  EXPECT_FLOAT_EQ(t.step().value()[2], -0.01f) << "the contact gain everywhere";
}

TEST(Controller, TheCommandCarriesTheSensorSamplesStamp) {
  ControllerUnderTest t;
  t.controller.reference_in().deliver(float6({1, 0, 0, 0, 0, 0}, 1'000'000'000'123'000));
  t.controller.sensor_in().deliver(float6({1, 0, 0, 0, 0, 0}, 1'000'000'000'456'000));
  t.step();
  EXPECT_EQ(rtm::to_ns(t.last().tm), 1'000'000'000'456'000);
}

TEST(Controller, NoDataAtAllWithholdsTheCommand) {
  ControllerUnderTest t;
  EXPECT_EQ(t.step(), kWithheld);
  EXPECT_EQ(t.controller.counters().withheld_commands, 1u);
}

TEST(Controller, StaleSensorWithholdsTheCommandNotRepeatingTheLastAndRecovers) {
  rtm::comp::ControllerParams p = ControllerUnderTest::gains({1, 1, 1, 1, 1, 1});
  p.stale_periods = 3;
  ControllerUnderTest t(p);
  t.controller.sensor_in().deliver(float6({1, 1, 1, 1, 1, 1}));
  t.controller.reference_in().deliver(float6({1, 1, 1, 1, 1, 1}));
  const std::array<float, 6> two{2, 2, 2, 2, 2, 2};
  EXPECT_EQ(t.step(), two);
  // The reference keeps coming; the sensor stops. Two more cycles still use the last sample.
  for (int i = 0; i < 2; ++i) {
    t.controller.reference_in().deliver(float6({1, 1, 1, 1, 1, 1}));
    EXPECT_EQ(t.step(), two) << "cycle " << i + 1 << " without a new sensor datum";
  }
  t.controller.reference_in().deliver(float6({1, 1, 1, 1, 1, 1}));
  EXPECT_EQ(t.step(), kWithheld) << "3 periods without a new sensor datum";
  EXPECT_EQ(t.controller.counters().stale_events, 1u);
  t.controller.reference_in().deliver(float6({1, 1, 1, 1, 1, 1}));
  EXPECT_EQ(t.step(), kWithheld);
  EXPECT_EQ(t.controller.counters().stale_events, 1u) << "one event, not one per cycle";
  t.controller.sensor_in().deliver(float6({3, 3, 3, 3, 3, 3}));
  t.controller.reference_in().deliver(float6({1, 1, 1, 1, 1, 1}));
  const std::array<float, 6> four{4, 4, 4, 4, 4, 4};
  EXPECT_EQ(t.step(), four);
}

TEST(Controller, StaleReferenceWithholdsTheCommand) {
  rtm::comp::ControllerParams p = ControllerUnderTest::gains({1, 1, 1, 1, 1, 1});
  p.stale_periods = 1;
  ControllerUnderTest t(p);
  t.controller.sensor_in().deliver(float6({1, 1, 1, 1, 1, 1}));
  t.controller.reference_in().deliver(float6({1, 1, 1, 1, 1, 1}));
  EXPECT_NE(t.step(), kWithheld);
  t.controller.sensor_in().deliver(float6({1, 1, 1, 1, 1, 1}));
  EXPECT_EQ(t.step(), kWithheld);
}

TEST(Controller, NonFiniteInputWithholdsTheCommandAndCountsOneEvent) {
  ControllerUnderTest t;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  for (int i = 0; i < 3; ++i) {
    t.controller.sensor_in().deliver(float6({1, nan, 1, 1, 1, 1}));
    t.controller.reference_in().deliver(float6({1, 1, 1, 1, inf, 1}));
    EXPECT_EQ(t.step(), kWithheld);
  }
  EXPECT_EQ(t.controller.counters().non_finite_events, 2u) << "one per input, not per cycle";
  t.controller.sensor_in().deliver(float6({1, 1, 1, 1, 1, 1}));
  t.controller.reference_in().deliver(float6({1, 1, 1, 1, 1, 1}));
  EXPECT_NE(t.step(), kWithheld);
}

TEST(Controller, DataThatArrivedWhileOffIsNotUsedAfterOn) {
  ControllerUnderTest t;
  t.controller.sensor_in().deliver(float6({1, 1, 1, 1, 1, 1}));
  t.controller.reference_in().deliver(float6({1, 1, 1, 1, 1, 1}));
  t.controller.on_start();
  EXPECT_EQ(t.step(), kWithheld);
}

TEST(Controller, NonFiniteGainOrZeroStalePeriodsIsRefused) {
  rtm::comp::ControllerParams p;
  p.gain[4] = std::numeric_limits<float>::infinity();
  EXPECT_THROW(rtm::comp::Controller("c", p), std::invalid_argument);
  rtm::comp::ControllerParams q;
  q.stale_periods = 0;
  EXPECT_THROW(rtm::comp::Controller("c", q), std::invalid_argument);
}

TEST(Controller, PortsAreNamedForWhatTheyCarryAndDescribeTheirUnits) {
  ControllerUnderTest t;
  const auto& c = t.controller;
  ASSERT_EQ(c.in_ports().size(), 2u);
  EXPECT_EQ(c.in_ports()[0]->port_name(), "wrench");
  EXPECT_EQ(c.in_ports()[1]->port_name(), "reference");
  EXPECT_EQ(c.out_ports()[0]->port_name(), "twist");
  EXPECT_EQ(c.in_ports()[1]->info().elements[2].unit, "N");
  EXPECT_EQ(c.out_ports()[0]->info().elements[3].name, "wx");
  EXPECT_EQ(c.out_ports()[0]->info().elements[3].unit, "rad/s");
}

TEST(Controller, AGainSetWhileRunningIsUsedFromTheNextCycleWhole) {
  ControllerUnderTest t(ControllerUnderTest::gains({1, 1, 1, 1, 1, 1}));
  t.controller.reference_in().deliver(float6({1, 1, 1, 1, 1, 1}));
  t.controller.sensor_in().deliver(float6({0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(t.step(), (std::array<float, 6>{1, 1, 1, 1, 1, 1}));
  parameter(t.controller, "gain").set("2 3 4 5 6 7");
  t.controller.reference_in().deliver(float6({1, 1, 1, 1, 1, 1}));
  t.controller.sensor_in().deliver(float6({0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(t.step(), (std::array<float, 6>{2, 3, 4, 5, 6, 7}));
  EXPECT_EQ(parameter(t.controller, "gain").get(), "2 3 4 5 6 7");
  EXPECT_EQ(t.controller.params().gain, (std::array<float, 6>{2, 3, 4, 5, 6, 7}));
}

TEST(Controller, AGainWithFiveValuesOrANanIsRefusedAndTheOldGainStays) {
  ControllerUnderTest t(ControllerUnderTest::gains({1, 1, 1, 1, 1, 1}));
  EXPECT_THROW(parameter(t.controller, "gain").set("1 2 3 4 5"), std::invalid_argument);
  EXPECT_THROW(parameter(t.controller, "gain").set("1 2 3 4 5 nan"), std::invalid_argument);
  EXPECT_EQ(parameter(t.controller, "gain").get(), "1 1 1 1 1 1");
  EXPECT_EQ(parameter(t.controller, "stale_periods").access, rtm::ParameterAccess::when_off);
  EXPECT_THROW(parameter(t.controller, "stale_periods").set("0"), std::invalid_argument);
}

TEST(Controller, StalePeriodsSetWhileOffTakeEffectAtTheNextOn) {
  ControllerUnderTest t;
  parameter(t.controller, "stale_periods").set("1");
  t.controller.on_start();
  t.controller.reference_in().deliver(float6({1, 0, 0, 0, 0, 0}));
  t.controller.sensor_in().deliver(float6({1, 0, 0, 0, 0, 0}));
  EXPECT_NE(t.step(), kWithheld);
  EXPECT_EQ(t.step(), kWithheld) << "one cycle without data is stale now";
  EXPECT_EQ(statistic(t.controller, "stale_events"), 2.0) << "both inputs went stale";
  EXPECT_EQ(statistic(t.controller, "commands"), 1.0);
  EXPECT_EQ(statistic(t.controller, "withheld_commands"), 1.0);
}

}  // namespace
