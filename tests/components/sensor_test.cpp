// SPDX-License-Identifier: Apache-2.0
// The force-sensor component without CORBA, on the wrist's node: the frame change to the base
// frame, one datum per new wrench, fresh stamps, and source faults (the heartbeat-loss recovery
// against the simulator's sensor node is in sensor_recovery_test.cpp); on the joystick's node:
// the operator's force passes unchanged (its frame is base-aligned) under the same rules.
#include "components/sensor/sensor.h"

#include "component_test_support.h"
#include "rtm_test/fake_force_source.h"
#include "rtm_test/urdf.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <numbers>

namespace {

using comp_test::cycle;
using comp_test::values;

// The "ready" keyframe of sim/models/pa10_scene.xml: tool pointing straight down.
constexpr std::array<double, 7> kReadyPose_rad{0, 0.360534478941, 0, 1.828143726078, 0, 0.952914448571, 0};

using rtm_test::FakeForceSource;

rtm::pa10::Kinematics model() { return rtm::pa10::Kinematics::pa10(); }

struct SensorUnderTest {
  FakeForceSource* source = nullptr;
  std::unique_ptr<rtm::comp::Sensor> sensor;
  SensorUnderTest() {
    auto fake = std::make_unique<FakeForceSource>();
    source = fake.get();
    source->sample.q_rad = kReadyPose_rad;
    sensor = rtm::comp::Sensor::wrist("sensor0", std::move(fake), model());
  }
  void new_wrench(std::array<double, 6> w) { source->push(w); }
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

// On a chain written inline (seven joints about z; the tool turned half about x, pointing
// down): the frame change can be worked out by hand. Sensor z (along the tool) is base -z, and
// a quarter turn of joint 1 takes sensor x to base y.
TEST(SensorFrame, OnAnInlineChainTheWrenchTurnsAsTheChainDoes) {
  const std::string urdf = rtm_test::serial_chain_urdf(std::vector<rtm_test::UrdfJoint>(7, {.xyz = {0, 0, 0.1}}),
                                                       {0, 0, 0.05}, {std::numbers::pi, 0, 0});
  auto fake = std::make_unique<FakeForceSource>();
  FakeForceSource* source = fake.get();
  auto sensor = rtm::comp::Sensor::wrist("sensor_inline", std::move(fake),
                                         rtm::pa10::Kinematics::from_urdf_string(urdf, "inline.urdf"));
  sensor->on_start();
  source->sample.q_rad = {};
  source->push({2, 0, -10, 0, 0.5, 0});
  sensor->on_cycle(cycle(0));
  RTM::TimedFloat6 out{};
  ASSERT_TRUE(sensor->out().latest(out));
  std::array<float, 6> expected{2, 0, 10, 0, -0.5f, 0};  // R = Rx(pi): y and z change sign
  for (std::size_t i = 0; i < 6; ++i) EXPECT_NEAR(values(out)[i], expected[i], 1e-5) << i;
  source->sample.q_rad = {std::numbers::pi / 2, 0, 0, 0, 0, 0, 0};
  source->push({2, 0, -10, 0, 0.5, 0});
  sensor->on_cycle(cycle(1));
  ASSERT_TRUE(sensor->out().latest(out));
  expected = {0, 2, 10, 0.5f, 0, 0};  // R = Rz(pi/2) Rx(pi)
  for (std::size_t i = 0; i < 6; ++i) EXPECT_NEAR(values(out)[i], expected[i], 1e-5) << i;
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
    rtm::comp::Sensor::wrist("wrist7", nullptr, model());
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("wrist7"), std::string::npos);
  }
}

TEST(Sensor, TheWristWritesNothingUntilTheJointsAreHeardAndNeedsTheArmModel) {
  SensorUnderTest t;
  t.sensor->on_start();
  t.new_wrench({0, 0, -10, 0, 0, 0});
  t.source->sample.q_valid = false;  // no SYNC answered by every drive yet
  t.sensor->on_cycle(cycle(0));
  EXPECT_EQ(t.sensor->counters().samples, 0u) << "a wrench in a frame it cannot turn";
  t.source->sample.q_valid = true;
  t.sensor->on_cycle(cycle(1));
  EXPECT_EQ(t.sensor->counters().samples, 1u);
  try {
    rtm::comp::Sensor("wrist8", rtm::can::ForceSensor::wrist, std::make_unique<FakeForceSource>(), std::nullopt);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("wrist8: the wrist sensor needs the arm's kinematics"), std::string::npos)
        << e.what();
  }
}

// ---- the same component on the joystick's node ----------------------------------------------

struct JoystickUnderTest {
  FakeForceSource* source = nullptr;
  std::unique_ptr<rtm::comp::Sensor> joystick;
  JoystickUnderTest() {
    auto fake = std::make_unique<FakeForceSource>();
    source = fake.get();
    joystick = rtm::comp::Sensor::joystick("joystick0", std::move(fake));
  }
  void push(std::array<double, 6> w) {
    source->push(w);
    source->sample.q_valid = false;  // its frame needs no joints
  }
  void fault(rtm::can::FaultKind kind, std::string why) { source->why = {kind, rtm::can::kJoystickSensorNode, 0, why}; }
};

TEST(SensorAsJoystick, IsTheJoystickKindWritingItsReferencePort) {
  JoystickUnderTest t;
  EXPECT_EQ(t.joystick->kind(), "joystick");
  EXPECT_EQ(t.joystick->node(), rtm::can::ForceSensor::joystick);
  ASSERT_EQ(t.joystick->out_ports().size(), 1u);
  EXPECT_EQ(t.joystick->out_ports()[0]->full_name(), "joystick0.reference");
  SensorUnderTest wrist;
  EXPECT_EQ(wrist.sensor->kind(), "sensor");
  EXPECT_EQ(wrist.sensor->out_ports()[0]->full_name(), "sensor0.wrench");
}

TEST(SensorAsJoystick, OperatorPushingDownIsADownwardReferenceUnchanged) {
  JoystickUnderTest t;
  t.joystick->on_start();
  t.push({0.5, -1.5, -10, 0.1, 0, -0.2});
  t.joystick->on_cycle(cycle(0));
  RTM::TimedFloat6 out{};
  ASSERT_TRUE(t.joystick->out().latest(out));
  const std::array<float, 6> expected{0.5f, -1.5f, -10.0f, 0.1f, 0.0f, -0.2f};
  EXPECT_EQ(values(out), expected);
}

TEST(SensorAsJoystick, WritesOnlyNewReadings) {
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

TEST(SensorAsJoystick, SourceFaultThrowsTheReason) {
  JoystickUnderTest t;
  t.joystick->on_start();
  t.fault(rtm::can::FaultKind::emergency, "joystick sensor 0x11: EMCY 0x7300");
  try {
    t.joystick->on_cycle(cycle(0));
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "joystick sensor 0x11: EMCY 0x7300");
  }
}

// A silent joystick node (the simulator's process stalled) is waited out: nothing is written
// meanwhile, not even a wrench read before the loss; heard again with a newer one, the
// joystick writes again, the loss and the recovery counted once each.
TEST(SensorAsJoystick, AHeartbeatGapIsWaitedOutAndTheJoystickWritesAgainWhenHeard) {
  JoystickUnderTest t;
  t.joystick->on_start();
  t.push({1, 0, 0, 0, 0, 0});
  t.joystick->on_cycle(cycle(0));
  ASSERT_EQ(t.joystick->counters().samples, 1u);
  t.fault(rtm::can::FaultKind::heartbeat_lost, "joystick sensor 0x11: no heartbeat for 301 ms");
  for (int i = 1; i < 50; ++i) EXPECT_NO_THROW(t.joystick->on_cycle(cycle(i))) << i;
  EXPECT_EQ(t.joystick->counters().heartbeat_losses, 1u);
  t.fault(rtm::can::FaultKind::none, "");
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

TEST(SensorAsJoystick, AHeartbeatGapLongerThanTheBudgetIsAnError) {
  JoystickUnderTest t;
  t.joystick->on_start();
  t.fault(rtm::can::FaultKind::heartbeat_lost, "joystick sensor 0x11: no heartbeat for 301 ms");
  const std::uint32_t budget = rtm::comp::SensorParams{}.recovery_timeout_periods;
  std::uint64_t n = 0;
  for (; n < budget; ++n) ASSERT_NO_THROW(t.joystick->on_cycle(cycle(n))) << n;
  try {
    t.joystick->on_cycle(cycle(n));
    FAIL() << "no error after the budget";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("joystick sensor 0x11: no heartbeat for 301 ms: not back within the "
                                         "recovery budget of 1000 cycles"),
              std::string::npos)
        << e.what();
  }
  // Another fault while the node is silent is no stall: thrown at once.
  JoystickUnderTest other;
  other.joystick->on_start();
  other.fault(rtm::can::FaultKind::heartbeat_lost, "joystick sensor 0x11: no heartbeat for 301 ms");
  other.joystick->on_cycle(cycle(0));
  other.fault(rtm::can::FaultKind::emergency, "joystick sensor 0x11: EMCY 0x7300");
  EXPECT_THROW(other.joystick->on_cycle(cycle(1)), std::runtime_error);
}

}  // namespace
