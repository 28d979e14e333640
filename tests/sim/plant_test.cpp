// SPDX-License-Identifier: Apache-2.0
// The MuJoCo plant's joint servos and sensors: no sag on the brakes, velocity following,
// an ideal brake, and the sign and frame of both force sensors.
#include "sim/pa10_plant.h"

#include "rtm_test/mjcf.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

using rtm::sim::JointCommand;
using rtm::sim::Pa10Plant;
using rtm::sim::SceneError;
using rtm::sim::Wrench;
using rtm::sim::kJointCount;

namespace {

constexpr double kToolMass_kg = 0.10;
constexpr double kHandleMass_kg = 0.20;
constexpr double kGravity_m_s2 = 9.81;

TEST(Pa10Plant, HoldingTheReadyPoseForTwoSecondsDoesNotSag) {
  Pa10Plant plant(RTM_PA10_SCENE);
  std::array<double, kJointCount> start{};
  for (int j = 0; j < kJointCount; ++j) start[static_cast<std::size_t>(j)] = plant.joint_state(j).position_rad;
  for (int i = 0; i < 2000; ++i) plant.step();
  for (int j = 0; j < kJointCount; ++j)
    EXPECT_NEAR(plant.joint_state(j).position_rad, start[static_cast<std::size_t>(j)], 1e-5) << "joint " << j;
}

TEST(Pa10Plant, VelocityModeFollowsTheTargetAndItsIntegral) {
  Pa10Plant plant(RTM_PA10_SCENE);
  const double start_rad = plant.joint_state(1).position_rad;
  // Backwards: lifts the tool off the table (forwards it would touch the table).
  plant.set_command(1, {JointCommand::Mode::velocity, -0.2});
  for (int i = 0; i < 1500; ++i) plant.step();
  EXPECT_NEAR(plant.joint_state(1).velocity_rad_s, -0.2, 1e-3);
  // The PI loop makes up the start-up lag: the position tracks the integral of the target.
  EXPECT_NEAR(plant.joint_state(1).position_rad - start_rad, -0.2 * 1.5, 1e-3);
  for (int j : {0, 2, 3, 4, 5, 6}) EXPECT_NEAR(plant.joint_state(j).velocity_rad_s, 0.0, 1e-3);
}

TEST(Pa10Plant, BrakeStopsTheJointAtOnceAndHoldsThere) {
  Pa10Plant plant(RTM_PA10_SCENE);
  plant.set_command(3, {JointCommand::Mode::velocity, -0.5});
  for (int i = 0; i < 1000; ++i) plant.step();
  ASSERT_NEAR(plant.joint_state(3).velocity_rad_s, -0.5, 1e-2);
  const double braked_at_rad = plant.joint_state(3).position_rad;
  plant.set_command(3, {});
  EXPECT_EQ(plant.joint_state(3).velocity_rad_s, 0.0);
  for (int i = 0; i < 500; ++i) plant.step();
  EXPECT_NEAR(plant.joint_state(3).position_rad, braked_at_rad, 1e-4);
  EXPECT_NEAR(plant.joint_state(3).velocity_rad_s, 0.0, 1e-3);
}

TEST(Pa10Plant, BrakeHoldsTheLoadOfAJointPressingOnTheTableAndHandsItBack) {
  Pa10Plant plant(RTM_PA10_SCENE);
  const double weight_N = plant.wrist_wrench().force_N[2];
  auto pressing_N = [&] { return -(plant.wrist_wrench().force_N[2] - weight_N); };
  // E1 folds the forearm down onto the table until the tool presses with about 10 N.
  plant.set_command(3, {JointCommand::Mode::velocity, 0.02});
  for (int i = 0; i < 20000 && pressing_N() < 10.0; ++i) plant.step();
  ASSERT_GE(pressing_N(), 10.0);
  plant.set_command(3, {JointCommand::Mode::velocity, 0.0});
  for (int i = 0; i < 1000; ++i) plant.step();
  const double held_by_the_loop_N = pressing_N();
  ASSERT_GT(held_by_the_loop_N, 5.0);
  plant.set_command(3, {});
  for (int i = 0; i < 500; ++i) plant.step();
  EXPECT_NEAR(pressing_N(), held_by_the_loop_N, 0.5) << "the brake holds the load";
  plant.set_command(3, {JointCommand::Mode::velocity, 0.0});
  double worst_N = 0;
  for (int i = 0; i < 500; ++i) {
    plant.step();
    worst_N = std::max(worst_N, std::abs(pressing_N() - held_by_the_loop_N));
  }
  EXPECT_LE(worst_N, 0.5) << "releasing the brake hands the load back without a jolt";
}

TEST(Pa10Plant, WristSensorFeelsTheToolWeightAlongItsZWhenTheToolPointsDown) {
  Pa10Plant plant(RTM_PA10_SCENE);
  for (int i = 0; i < 50; ++i) plant.step();
  const Wrench wrench = plant.wrist_wrench();
  // Gravity pulls the tool away from the flange, i.e. along +z of the flange frame.
  EXPECT_NEAR(wrench.force_N[2], kToolMass_kg * kGravity_m_s2, 1e-3);
  EXPECT_NEAR(wrench.force_N[0], 0.0, 1e-3);
  EXPECT_NEAR(wrench.force_N[1], 0.0, 1e-3);
  EXPECT_NEAR(wrench.torque_Nm[0], 0.0, 1e-4);
  EXPECT_NEAR(wrench.torque_Nm[1], 0.0, 1e-4);
}

TEST(Pa10Plant, JoystickReportsTheOperatorsWrenchPlusTheHandleWeight) {
  Pa10Plant plant(RTM_PA10_SCENE);
  plant.set_operator_wrench(Wrench{{5.0, -2.0, -3.0}, {0.0, 0.0, 0.4}});
  plant.step();
  plant.step();
  const Wrench wrench = plant.joystick_wrench();
  EXPECT_NEAR(wrench.force_N[0], 5.0, 1e-6);
  EXPECT_NEAR(wrench.force_N[1], -2.0, 1e-6);
  EXPECT_NEAR(wrench.force_N[2], -3.0 - kHandleMass_kg * kGravity_m_s2, 1e-6);
  EXPECT_NEAR(wrench.torque_Nm[2], 0.4, 1e-6);
  // The wrench is taken at the sensor origin, not where MuJoCo applies it (the handle's COM).
  EXPECT_NEAR(wrench.torque_Nm[0], 0.0, 1e-6);
  EXPECT_NEAR(wrench.torque_Nm[1], 0.0, 1e-6);
}

TEST(Pa10Plant, MissingOrBrokenSceneIsAClearError) {
  try {
    Pa10Plant plant("/nonexistent/scene.xml");
    FAIL() << "no error";
  } catch (const SceneError& error) {
    EXPECT_NE(std::string(error.what()).find("/nonexistent/scene.xml: scene file not found"),
              std::string::npos);
  }
  EXPECT_THROW(Pa10Plant plant(RTM_PA10_URDF), SceneError) << "a URDF without the scene's names";
}

TEST(Pa10Plant, ASceneLackingAnyNameItDrivesOrReadsIsRefusedNamingIt) {
  {
    const rtm_test::SceneFile complete(rtm_test::plant_scene_mjcf({}));
    EXPECT_NO_THROW(Pa10Plant plant(complete.path())) << "the inline scene has every name";
  }
  for (const char* name : {"s1", "s2", "s3", "e1", "e2", "w1", "w2", "joystick_handle", "joystick_ft", "tool_tip",
                           "wrist_force", "wrist_torque", "joystick_force", "joystick_torque", "ready"}) {
    rtm_test::MjcfScene scene;
    scene.renamed = name;
    const rtm_test::SceneFile file(rtm_test::plant_scene_mjcf(scene));
    try {
      Pa10Plant plant(file.path());
      ADD_FAILURE() << "a scene without '" << name << "' was taken";
    } catch (const SceneError& error) {
      EXPECT_NE(std::string(error.what()).find(std::string("'") + name + "'"), std::string::npos) << error.what();
    }
  }
}

TEST(Pa10Plant, TheWristSensorReadsTheWeightOfAToolOfKnownMassInItsOwnFrame) {
  // s2 turns about x by 90 degrees: the rest of the chain lies along -y, and the tool's y axis
  // points up. Held there, the tool's weight is -m g along its y, and about the sensor (the
  // tool's origin, its centre of mass c along its z) the torque (0, 0, c) x (0, -m g, 0).
  rtm_test::MjcfScene scene;
  scene.tool_mass_kg = 0.5;
  scene.tool_com_m = 0.05;
  scene.joints[1].axis = {1, 0, 0};
  scene.joints[1].ready_rad = std::numbers::pi / 2;
  const rtm_test::SceneFile file(rtm_test::plant_scene_mjcf(scene));
  Pa10Plant plant(file.path());
  for (int i = 0; i < 200; ++i) plant.step();
  EXPECT_NEAR(plant.joint_state(1).position_rad, std::numbers::pi / 2, 1e-4) << "the brake holds the lever";
  const double weight_N = scene.tool_mass_kg * kGravity_m_s2;
  const Wrench wrench = plant.wrist_wrench();
  EXPECT_NEAR(wrench.force_N[0], 0.0, 1e-3);
  EXPECT_NEAR(wrench.force_N[1], -weight_N, 1e-3);
  EXPECT_NEAR(wrench.force_N[2], 0.0, 1e-3);
  EXPECT_NEAR(wrench.torque_Nm[0], scene.tool_com_m * weight_N, 1e-4);
  EXPECT_NEAR(wrench.torque_Nm[1], 0.0, 1e-4);
  EXPECT_NEAR(wrench.torque_Nm[2], 0.0, 1e-4);
}

}  // namespace

// The tip pressed on the table and dragged along it (S1 turning the whole arm): the friction
// is the surface's Coulomb coefficient times the normal force, against the slip, and the
// normal force stays steady while it slides. With MuJoCo's own friction cone on this contact
// one sample in ten read almost no force and the next nearly twice it.
TEST(Pa10Plant, TheTipSlidesOnTheTableWithCoulombFrictionAndASteadyNormalForce) {
  for (const double mu : {0.3, 0.0}) {
    rtm::sim::Surface surface = rtm::sim::default_surface();
    surface.friction = mu;
    Pa10Plant plant(RTM_PA10_SCENE, {}, surface);
    plant.set_command(3, {JointCommand::Mode::velocity, 0.02});  // E1 presses the tip down
    for (int i = 0; i < 20000 && plant.tool_normal_force_N() < 10.0; ++i) plant.step();
    ASSERT_GE(plant.tool_normal_force_N(), 10.0);
    plant.set_command(3, {JointCommand::Mode::velocity, 0.0});
    for (int i = 0; i < 500; ++i) plant.step();
    plant.set_command(0, {JointCommand::Mode::velocity, 0.02});  // S1: ~11 mm/s along the top
    for (int i = 0; i < 500; ++i) plant.step();
    double lowest_N = 1e9, highest_N = 0, ratio_sum = 0;
    const int steps = 1000;
    for (int i = 0; i < steps; ++i) {
      plant.step();
      // The wrist's force in the world frame (the sensor's axes are the tool's): its part
      // along the top is the friction, the tool's tilt whatever it is.
      const Wrench w = plant.wrist_wrench();
      const auto r = plant.tool_rotation();  // row-major, tool -> world
      const double fx = r[0] * w.force_N[0] + r[1] * w.force_N[1] + r[2] * w.force_N[2];
      const double fy = r[3] * w.force_N[0] + r[4] * w.force_N[1] + r[5] * w.force_N[2];
      const double normal_N = plant.tool_normal_force_N();
      lowest_N = std::min(lowest_N, normal_N);
      highest_N = std::max(highest_N, normal_N);
      ratio_sum += std::hypot(fx, fy) / normal_N;
    }
    SCOPED_TRACE("friction " + std::to_string(mu));
    EXPECT_GT(lowest_N, 5.0) << "the tip lost the table while sliding";
    EXPECT_LT(highest_N - lowest_N, 0.2 * highest_N) << "the normal force chattered";
    EXPECT_NEAR(ratio_sum / steps, mu, 0.03) << "tangential / normal force at the wrist";
  }
}
