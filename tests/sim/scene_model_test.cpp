// SPDX-License-Identifier: Apache-2.0
// The MJCF scene mirrors the URDF: tool0 pose from MuJoCo vs KDL forward kinematics over many
// random joint vectors, and the same masses, centres of mass, inertias and joint limits.
#include <gtest/gtest.h>
#include <kdl/chain.hpp>
#include <mujoco/mujoco.h>

#include <cmath>
#include <random>
#include <string>

#include "arm/pa10/kinematics.h"
#include "sim/pa10_plant.h"

using rtm::pa10::JointVector;
using rtm::pa10::Kinematics;
using rtm::sim::Pa10Plant;

namespace {

TEST(Pa10SceneMatchesUrdf, ToolPoseAgreesWithKdlWithin1nmOverRandomJointVectors) {
  Kinematics kinematics = Kinematics::pa10();
  Pa10Plant plant(RTM_PA10_SCENE);
  const auto& limits = kinematics.limits();
  std::mt19937_64 rng(20041);
  double worst_position_m = 0;
  double worst_rotation = 0;
  for (int sample = 0; sample < 1000; ++sample) {
    JointVector q;
    std::array<double, rtm::sim::kJointCount> q_array{};
    for (int j = 0; j < rtm::sim::kJointCount; ++j) {
      std::uniform_real_distribution<double> within(limits.lower_rad[j], limits.upper_rad[j]);
      q[j] = q_array[static_cast<std::size_t>(j)] = within(rng);
    }
    plant.set_joint_positions(q_array);
    const Eigen::Isometry3d expected = kinematics.tool_pose(q);
    const auto position = plant.tool_position_m();
    const auto rotation = plant.tool_rotation();
    for (int i = 0; i < 3; ++i) {
      worst_position_m = std::max(worst_position_m,
                                  std::abs(position[static_cast<std::size_t>(i)] - expected.translation()[i]));
      for (int k = 0; k < 3; ++k)
        worst_rotation = std::max(
            worst_rotation,
            std::abs(rotation[static_cast<std::size_t>(3 * i + k)] - expected.linear()(i, k)));
    }
  }
  EXPECT_LE(worst_position_m, 1e-9);
  EXPECT_LE(worst_rotation, 1e-9);
}

TEST(Pa10SceneMatchesUrdf, ReadyPosePointsTheToolDown55cmInFrontAnd2cmAboveTheTable) {
  Pa10Plant plant(RTM_PA10_SCENE);
  const auto position = plant.tool_position_m();
  EXPECT_NEAR(position[0], 0.55, 1e-6);
  EXPECT_NEAR(position[1], 0.0, 1e-9);
  const auto rotation = plant.tool_rotation();
  EXPECT_NEAR(rotation[8], -1.0, 1e-9) << "tool z points down";
  const mjModel* model = plant.model();
  // The top of the plate on the table's spring (sim/surface.h), at rest.
  const int table = mj_name2id(model, mjOBJ_GEOM, "table_top");
  ASSERT_GE(table, 0);
  const double table_top_m = plant.data()->geom_xpos[3 * table + 2] + model->geom_size[3 * table + 2];
  EXPECT_NEAR(position[2] - table_top_m, 0.02, 1e-6);
}

TEST(Pa10SceneMatchesUrdf, MassesCentresOfMassAndInertiasAgree) {
  Kinematics kinematics = Kinematics::pa10();
  Pa10Plant plant(RTM_PA10_SCENE);
  const mjModel* model = plant.model();
  const KDL::Chain& chain = kinematics.chain();
  int compared = 0;
  for (unsigned s = 0; s < chain.getNrOfSegments(); ++s) {
    const KDL::Segment& segment = chain.getSegment(s);
    const int body = mj_name2id(model, mjOBJ_BODY, segment.getName().c_str());
    ASSERT_GE(body, 0) << "no MJCF body for URDF link " << segment.getName();
    const KDL::RigidBodyInertia& inertia = segment.getInertia();
    const double mass_kg = inertia.getMass();
    EXPECT_NEAR(model->body_mass[body], mass_kg, 1e-9) << segment.getName();
    const KDL::Vector com = inertia.getCOG();
    for (int i = 0; i < 3; ++i)
      EXPECT_NEAR(model->body_ipos[3 * body + i], com[i], 1e-9) << segment.getName();
    // KDL keeps the rotational inertia about the segment origin; MuJoCo about the COM, in
    // principal axes (identity here: the URDF inertias are diagonal in the link frame).
    const KDL::RotationalInertia rotational = inertia.getRotationalInertia();
    const double* about_origin = rotational.data;
    const double com_sq = dot(com, com);
    for (int i = 0; i < 3; ++i) {
      const double about_com = about_origin[4 * i] - mass_kg * (com_sq - com[i] * com[i]);
      EXPECT_NEAR(model->body_inertia[3 * body + i], about_com, 1e-9) << segment.getName();
    }
    ++compared;
  }
  EXPECT_EQ(compared, 9) << "link1..link7, ft_sensor, tool0";
}

TEST(Pa10SceneMatchesUrdf, JointLimitsAgree) {
  Kinematics kinematics = Kinematics::pa10();
  Pa10Plant plant(RTM_PA10_SCENE);
  const mjModel* model = plant.model();
  for (int j = 0; j < rtm::sim::kJointCount; ++j) {
    EXPECT_EQ(std::string(mj_id2name(model, mjOBJ_JOINT, j)),
              kinematics.limits().names[static_cast<std::size_t>(j)]);
    EXPECT_NEAR(model->jnt_range[2 * j], kinematics.limits().lower_rad[j], 1e-12);
    EXPECT_NEAR(model->jnt_range[2 * j + 1], kinematics.limits().upper_rad[j], 1e-12);
  }
}

}  // namespace
