// SPDX-License-Identifier: Apache-2.0
// The wrist Sensor component without CORBA: the frame change to the base frame, one datum per
// new wrench, fresh stamps, and source faults (the heartbeat-loss recovery against the
// simulator's sensor node is in sensor_recovery_test.cpp).
#include "components/sensor/sensor.h"

#include "component_test_support.h"
#include "rtm_test/fake_wrist_source.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <numbers>

namespace {

using comp_test::cycle;
using comp_test::values;

// The "ready" keyframe of sim/models/pa10_scene.xml: tool pointing straight down.
constexpr std::array<double, 7> kReadyPose_rad{0, 0.360534478941, 0, 1.828143726078, 0, 0.952914448571, 0};

using rtm_test::FakeWristSource;

rtm::pa10::Kinematics model() { return rtm::pa10::Kinematics::pa10(); }

struct SensorUnderTest {
  FakeWristSource* source = nullptr;
  std::unique_ptr<rtm::comp::Sensor> sensor;
  SensorUnderTest() {
    auto fake = std::make_unique<FakeWristSource>();
    source = fake.get();
    source->sample.q_rad = kReadyPose_rad;
    sensor = std::make_unique<rtm::comp::Sensor>("sensor0", std::move(fake), model());
  }
  void new_wrench(std::array<double, 6> w) {
    source->sample.wrench_sensor = w;
    source->sample.valid = true;
    ++source->sample.sequence;
  }
};

TEST(SensorFrame, RotationTurnsForceAndTorqueIntoTheBaseFrame) {
  const Eigen::Matrix3d quarter_turn_about_z = Eigen::AngleAxisd(std::numbers::pi / 2, Eigen::Vector3d::UnitZ()).matrix();
  const auto base = rtm::comp::wrench_sensor_to_base(quarter_turn_about_z, {1, 0, 0, 0, 2, 0});
  EXPECT_NEAR(base[0], 0.0, 1e-12);
  EXPECT_NEAR(base[1], 1.0, 1e-12);
  EXPECT_NEAR(base[3], -2.0, 1e-12);
  EXPECT_NEAR(base[4], 0.0, 1e-12);
}

TEST(SensorFrame, TableReactionOnTheDownwardToolReadsUpwardInTheBaseFrame) {
  // Pressing on the table: the table pushes the tool back along the sensor's -z (the tool
  // points down, sensor z along the tool). In the base frame that is +Fz, the sign the
  // controller's gain*(ref + sen) needs against a downward reference.
  SensorUnderTest t;
  t.sensor->on_start();
  t.new_wrench({0, 0, -10, 0, 0, 0});
  t.sensor->on_cycle(cycle(0));
  RTM::TimedFloat6 out{};
  ASSERT_TRUE(t.sensor->out().latest(out));
  const auto v = values(out);
  EXPECT_NEAR(v[0], 0.0, 1e-3);
  EXPECT_NEAR(v[1], 0.0, 1e-3);
  EXPECT_NEAR(v[2], 10.0, 1e-3);
}

TEST(Sensor, WritesEachNewWrenchOnceWithTheTimeItWasRead) {
  SensorUnderTest t;
  t.sensor->on_start();
  t.new_wrench({1, 2, 3, 0, 0, 0});
  const std::int64_t before_ns = rtm::to_ns(rtm::now());
  t.sensor->on_cycle(cycle(0));
  const std::int64_t after_ns = rtm::to_ns(rtm::now());
  t.sensor->on_cycle(cycle(1));  // same wrench: nothing new to write
  EXPECT_EQ(t.sensor->counters().samples, 1u);
  RTM::TimedFloat6 out{};
  ASSERT_TRUE(t.sensor->out().latest(out));
  EXPECT_GE(rtm::to_ns(out.tm), before_ns);
  EXPECT_LE(rtm::to_ns(out.tm), after_ns);
  t.new_wrench({4, 5, 6, 0, 0, 0});
  t.sensor->on_cycle(cycle(2));
  EXPECT_EQ(t.sensor->counters().samples, 2u);
}

TEST(Sensor, WritesNothingBeforeAValidSampleOrForOneSeenBeforeOn) {
  SensorUnderTest t;
  t.sensor->on_start();
  t.sensor->on_cycle(cycle(0));
  EXPECT_EQ(t.sensor->counters().samples, 0u) << "no valid sample yet";
  t.new_wrench({1, 0, 0, 0, 0, 0});
  t.sensor->on_start();  // the sample existed before on(): not fresh
  t.sensor->on_cycle(cycle(1));
  EXPECT_EQ(t.sensor->counters().samples, 0u);
}

TEST(Sensor, SensorFaultWhileNothingNewArrivesThrowsTheReason) {
  SensorUnderTest t;
  t.sensor->on_start();
  t.source->why = {rtm::comp::FaultKind::emergency, 0x10, 0x7300, "wrist sensor 0x10: EMCY 0x7300 sensor fault"};
  try {
    t.sensor->on_cycle(cycle(0));
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("EMCY 0x7300"), std::string::npos) << e.what();
  }
  EXPECT_EQ(t.sensor->counters().heartbeat_losses, 0u);
}

// The race a bus leaves open: a wrench that arrives while the loss is being seen (after the
// cycle read the source) is from before the loss; when the node comes back, only a wrench newer
// than that is written.
TEST(Sensor, AfterAHeartbeatLossOnlyAWrenchNewerThanTheLossIsWritten) {
  SensorUnderTest t;
  t.sensor->on_start();
  t.new_wrench({0, 0, -1, 0, 0, 0});
  t.sensor->on_cycle(cycle(0));
  ASSERT_EQ(t.sensor->counters().samples, 1u);
  t.source->why = {rtm::comp::FaultKind::heartbeat_lost, 0x10, 0, "wrist sensor 0x10: no heartbeat for 301 ms"};
  t.source->when_fault_asked = [&] { t.new_wrench({0, 0, -2, 0, 0, 0}); };
  t.sensor->on_cycle(cycle(1));
  ASSERT_EQ(t.sensor->counters().heartbeat_losses, 1u);
  t.source->when_fault_asked = nullptr;
  t.source->why = {};  // the heartbeat is back; the newest wrench is still the one from before
  t.sensor->on_cycle(cycle(2));
  EXPECT_EQ(t.sensor->counters().samples, 1u) << "a wrench from before the loss was written";
  EXPECT_EQ(t.sensor->counters().heartbeat_recoveries, 0u);
  t.new_wrench({0, 0, -3, 0, 0, 0});
  t.sensor->on_cycle(cycle(3));
  EXPECT_EQ(t.sensor->counters().samples, 2u);
  EXPECT_EQ(t.sensor->counters().heartbeat_recoveries, 1u);
  RTM::TimedFloat6 out{};
  ASSERT_TRUE(t.sensor->out().latest(out));
  EXPECT_NEAR(values(out)[2], 3.0, 1e-3) << "the wrench after the loss (tool down: -Fz sensor reads +Fz base)";
}

TEST(Sensor, MissingSourceIsRefusedWithTheComponentName) {
  try {
    rtm::comp::Sensor sensor("wrist7", nullptr, model());
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("wrist7"), std::string::npos);
  }
}

}  // namespace
