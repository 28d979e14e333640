// SPDX-License-Identifier: Apache-2.0
// Pa10Rig on the kinematic plant, frame by frame in lock-step (no MuJoCo, no transport): the
// nine nodes boot, a SYNC advances the plant by exactly its period, a commanded velocity
// integrates exactly, and the sensors report the plant's wrenches.
#include "sim/pa10_rig.h"

#include <gtest/gtest.h>

#include "arm/can/protocol.h"
#include "lockstep_master.h"
#include "recording_sink.h"
#include "sim/kinematic_plant.h"

namespace rtm::sim {
namespace {

namespace pc = rtm::can;
using testing::LockStepMaster;
using testing::RecordingSink;

class KinematicRigTest : public ::testing::Test {
 protected:
  KinematicRigTest() : rig_(plant_, RigConfig{}) {
    rig_.set_mode(Pa10Rig::Mode::lock_step);
    rig_.power_on(out_);
  }

  KinematicPlant plant_;
  Pa10Rig rig_;
  RecordingSink out_;
  LockStepMaster<Pa10Rig> master_{rig_, out_};
};

TEST_F(KinematicRigTest, PowerOnBootsAllNineNodes) {
  EXPECT_EQ(out_.bootups(), 9);
  EXPECT_EQ(rig_.time_ns(), 0);
}

TEST_F(KinematicRigTest, EachSyncAdvancesTheSyncPeriodAndAVelocityIntegratesExactly) {
  master_.start_up();
  const double start_rad = plant_.joint_state(2).position_rad;
  const std::int64_t before_ns = rig_.time_ns();
  for (int i = 0; i < 10; ++i) master_.cycle_all(pc::controlword::kEnableOperation, 0.5);
  EXPECT_EQ(rig_.time_ns() - before_ns, 20'000'000);
  // The target latched at the first of these SYNCs acts from its own period on.
  EXPECT_NEAR(plant_.joint_state(2).position_rad - start_rad, 0.5 * 0.020, 1e-12);
  const auto tpdos = out_.with_id(pc::cob::kTpdo1Base + pc::drive_node(2));
  ASSERT_FALSE(tpdos.empty());
  const auto feedback = pc::decode_drive_feedback(tpdos.back());
  ASSERT_TRUE(feedback.ok());
  EXPECT_NEAR(feedback->position_rad - start_rad, 0.010, 2e-6);  // 1 µrad on the bus
  EXPECT_NEAR(feedback->velocity_rad_s, 0.5, 1e-3);
}

TEST_F(KinematicRigTest, TheSensorsReportTheWristContactAndTheOperatorsWrench) {
  master_.start_up();
  plant_.set_wrist_wrench({{1.5, 0, -2.0}, {0, 0.25, 0}});
  rig_.set_operator_override({{0, 3.0, 0}, {0, 0, -0.5}});
  out_.clear();
  master_.cycle(pc::controlword::kEnableOperation);
  const auto wrist = pc::decode_sensor_force(out_.with_id(pc::cob::kTpdo1Base + pc::kWristSensorNode).at(0));
  const auto wrist_torque = pc::decode_sensor_torque(out_.with_id(pc::cob::kTpdo2Base + pc::kWristSensorNode).at(0));
  const auto joystick = pc::decode_sensor_force(out_.with_id(pc::cob::kTpdo1Base + pc::kJoystickSensorNode).at(0));
  const auto joystick_torque =
      pc::decode_sensor_torque(out_.with_id(pc::cob::kTpdo2Base + pc::kJoystickSensorNode).at(0));
  EXPECT_NEAR(wrist->force_N[0], 1.5, 1e-9);
  EXPECT_NEAR(wrist->force_N[2], -2.0, 1e-9);
  EXPECT_NEAR(wrist_torque->torque_Nm[1], 0.25, 1e-9);
  EXPECT_NEAR(joystick->force_N[1], 3.0, 1e-9);
  EXPECT_NEAR(joystick_torque->torque_Nm[2], -0.5, 1e-9);
}

TEST(KinematicRig, ATimestepThatDoesNotDivideTheSyncPeriodIsRefused) {
  KinematicPlant plant(0.0015);
  EXPECT_THROW(Pa10Rig(plant, RigConfig{}), RigError);
}

}  // namespace
}  // namespace rtm::sim
