// SPDX-License-Identifier: Apache-2.0
// The simulator in lock-step, driven frame by frame in-process (no transport): startup, a
// velocity command moving the joint, and the command-loss brake timed in SYNCs of sim time.
#include "sim/simulator.h"

#include <gtest/gtest.h>

#include "arm/can/protocol.h"
#include "rtm_test/allocation_counter.h"
#include "lockstep_master.h"
#include "recording_sink.h"

namespace rtm::sim {
namespace {

namespace pc = rtm::can;
using testing::LockStepMaster;
using testing::RecordingSink;

class LockStepSimulatorTest : public ::testing::Test {
 protected:
  LockStepSimulatorTest() : sim_(config()) {
    sim_.set_mode(Pa10Simulator::Mode::lock_step);
    sim_.power_on(out_);
  }
  static SimulatorConfig config() {
    SimulatorConfig config;
    config.scene_path = RTM_PA10_SCENE;
    return config;
  }

  Pa10Simulator sim_;
  RecordingSink out_;
  LockStepMaster<Pa10Simulator> master_{sim_, out_};
};

TEST_F(LockStepSimulatorTest, PowerOnBootsAllNineNodesAtSimTimeZero) {
  EXPECT_EQ(out_.bootups(), 9);
  EXPECT_EQ(sim_.time_ns(), 0);
}

TEST_F(LockStepSimulatorTest, EachSyncAdvancesTwoMillisecondsAndIsAnsweredByEveryNode) {
  master_.start_up();
  const std::int64_t before_ns = sim_.time_ns();
  out_.clear();
  master_.cycle(pc::controlword::kEnableOperation);
  EXPECT_EQ(sim_.time_ns() - before_ns, 2'000'000);
  EXPECT_EQ(sim_.steps(), 8u) << "4 SYNCs, 2 steps each";
  for (int j = 0; j < 7; ++j) {
    const auto feedback = master_.last_feedback(j);
    ASSERT_TRUE(feedback) << "drive " << j + 1;
    EXPECT_EQ(feedback->statusword, pc::statusword::kOperationEnabled);
  }
  for (std::uint8_t node : {pc::kWristSensorNode, pc::kJoystickSensorNode}) {
    EXPECT_EQ(out_.with_id(pc::cob::kTpdo1Base + node).size(), 1u);
    EXPECT_EQ(out_.with_id(pc::cob::kTpdo2Base + node).size(), 1u);
  }
}

TEST_F(LockStepSimulatorTest, CommandedJointVelocityMovesTheJointByItsIntegral) {
  master_.start_up();
  const double start_rad = sim_.plant().joint_state(0).position_rad;
  for (int i = 0; i < 250; ++i) master_.cycle(pc::controlword::kEnableOperation, {0.4, 0, 0, 0, 0, 0, 0});
  for (int i = 0; i < 500; ++i) master_.cycle(pc::controlword::kEnableOperation);
  const auto feedback = master_.last_feedback(0);
  ASSERT_TRUE(feedback);
  EXPECT_NEAR(feedback->position_rad - start_rad, 0.4 * 0.5, 2e-3);
  EXPECT_NEAR(feedback->velocity_rad_s, 0.0, 2e-3);
}

TEST_F(LockStepSimulatorTest, WithoutRpdosEveryDriveBrakesToZeroWithinThreeSyncs) {
  master_.start_up();
  // Every joint moving; the pitch joints backwards so the tool rises clear of the table.
  for (int i = 0; i < 100; ++i)
    master_.cycle(pc::controlword::kEnableOperation, {0.3, -0.3, 0.3, -0.3, 0.3, -0.3, 0.3});
  const std::int64_t last_rpdo_ns = sim_.time_ns();
  out_.clear();
  master_.sync_only();
  master_.sync_only();
  master_.sync_only();
  EXPECT_EQ(sim_.time_ns() - last_rpdo_ns, 6'000'000);
  for (int j = 0; j < 7; ++j) {
    const auto feedback = master_.last_feedback(j);
    ASSERT_TRUE(feedback);
    EXPECT_EQ(feedback->statusword & pc::statusword::kStateMask, pc::statusword::kFault);
    EXPECT_NEAR(feedback->velocity_rad_s, 0.0, 1e-3) << "drive " << j + 1;
    const auto emcy = out_.with_id(pc::cob::kEmcyBase + pc::drive_node(j));
    ASSERT_EQ(emcy.size(), 1u);
    EXPECT_EQ(pc::decode_emcy(emcy[0])->error_code, pc::emcy::kRpdoTimeout);
  }
}

TEST_F(LockStepSimulatorTest, ASyncCycleAllocatesNothing) {
  master_.start_up();
  master_.cycle(pc::controlword::kEnableOperation, {0.1, 0, 0, 0, 0, 0, 0});
  out_.frames.reserve(out_.frames.size() + 10000);  // the recording sink's own growth
  const auto before = rtm_test::allocations_total();
  for (int i = 0; i < 200; ++i) master_.cycle(pc::controlword::kEnableOperation, {0.1, 0, 0, 0, 0, 0, 0});
  EXPECT_EQ(rtm_test::allocations_total() - before, 0u);
}

TEST_F(LockStepSimulatorTest, WithASeparateSensorBusTheSensorsAnswerOnlyThere) {
  RecordingSink sensor_bus;
  sim_.set_sensor_sink(&sensor_bus);
  master_.start_up();
  out_.clear();
  master_.cycle(pc::controlword::kEnableOperation);
  EXPECT_TRUE(out_.with_id(pc::cob::kTpdo1Base + pc::kWristSensorNode).empty());
  EXPECT_EQ(out_.with_id(pc::cob::kTpdo1Base + pc::drive_node(0)).size(), 1u);
  EXPECT_TRUE(sensor_bus.with_id(pc::cob::kTpdo1Base + pc::kWristSensorNode).empty())
      << "the sensors are not operational on their bus yet";
  sim_.on_sensor_bus_frame(*pc::encode_nmt(pc::NmtCommand::start, 0));
  const std::int64_t before_ns = sim_.time_ns();
  sim_.on_sensor_bus_frame(*pc::encode_sync(1));
  EXPECT_EQ(sim_.time_ns(), before_ns) << "a sensor-bus SYNC never advances the physics";
  for (std::uint8_t node : {pc::kWristSensorNode, pc::kJoystickSensorNode}) {
    EXPECT_EQ(sensor_bus.with_id(pc::cob::kTpdo1Base + node).size(), 1u);
    EXPECT_EQ(sensor_bus.with_id(pc::cob::kTpdo2Base + node).size(), 1u);
  }
}

TEST(LockStepSimulator, JoystickReportsTheProfilesWrenchOverSimTimeThenTheOverride) {
  SimulatorConfig config;
  config.scene_path = RTM_PA10_SCENE;
  config.operator_profile = rtm::sim::OperatorProfile::from_yaml(
      "segments:\n  - hold: 0.02\n  - step: {force_N: [3, 0, -4], torque_Nm: [0, 0.5, 0]}\n",
      "inline");
  Pa10Simulator sim(config);
  sim.set_mode(Pa10Simulator::Mode::lock_step);
  RecordingSink out;
  sim.power_on(out);
  sim.on_frame(*pc::encode_nmt(pc::NmtCommand::start, 0), out);
  auto joystick_after_sync = [&](std::uint8_t counter) {
    out.clear();
    sim.on_frame(*pc::encode_sync(counter), out);
    const auto force = pc::decode_sensor_force(
        out.with_id(pc::cob::kTpdo1Base + pc::kJoystickSensorNode).at(0));
    const auto torque = pc::decode_sensor_torque(
        out.with_id(pc::cob::kTpdo2Base + pc::kJoystickSensorNode).at(0));
    return std::make_pair(force->force_N, torque->torque_Nm);
  };
  const auto [before, unused] = joystick_after_sync(1);  // t = 2 ms: hands off
  for (double f : before) EXPECT_NEAR(f, 0.0, 0.015);
  for (std::uint8_t counter = 2; counter < 12; ++counter) joystick_after_sync(counter);
  const auto [force, torque] = joystick_after_sync(12);  // t = 24 ms
  EXPECT_NEAR(force[0], 3.0, 0.015);
  EXPECT_NEAR(force[1], 0.0, 0.015);
  EXPECT_NEAR(force[2], -4.0, 0.015);
  EXPECT_NEAR(torque[1], 0.5, 0.0015);
  sim.set_operator_override(rtm::sim::Wrench{{0, 7, 0}, {0, 0, 0}});
  const auto [overridden, unused2] = joystick_after_sync(13);
  EXPECT_NEAR(overridden[0], 0.0, 0.015);
  EXPECT_NEAR(overridden[1], 7.0, 0.015);
}

TEST_F(LockStepSimulatorTest, SensorsAreTaredSoTheyReadZeroAtRest) {
  master_.start_up();
  master_.cycle(pc::controlword::kEnableOperation);
  const auto force = pc::decode_sensor_force(
      out_.with_id(pc::cob::kTpdo1Base + pc::kWristSensorNode).back());
  ASSERT_TRUE(force.ok());
  for (double f : force->force_N) EXPECT_NEAR(f, 0.0, 0.02);
  EXPECT_NEAR(sim_.wrist_sensor().offset().force_N[2], 0.981, 1e-2);
}

}  // namespace
}  // namespace rtm::sim
