// The Controller without CORBA: Fig. 6's arithmetic, stale and non-finite inputs give a zero
// command (never the last one), the command carries the sensor sample's stamp.
#include "components/controller/controller.h"

#include "component_test_support.h"

#include <gtest/gtest.h>

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
  EXPECT_EQ(t.controller.counters().withheld, 1u);
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
