// SPDX-License-Identifier: Apache-2.0
// The PA10 model and kinematics: URDF loading, FK against an independent DH product, the
// Jacobian, and the velocity IK's damping, limit handling and input checks.
#include "arm/pa10/kinematics.h"
#include "rtm_test/allocation_counter.h"
#include "rtm_test/urdf.h"

#include <gtest/gtest.h>

#include <kdl/chain.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>

namespace rtm::pa10 {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;
constexpr double kDt_s = 0.002;

// The PA10-7C standard DH parameters, restated here on purpose: the URDF is checked against
// them, not against itself.
constexpr std::array<double, 7> kDh_d_m{0.317, 0, 0.450, 0, 0.480, 0, 0.070};
constexpr std::array<double, 7> kDh_alpha_rad{-kPi / 2, kPi / 2, -kPi / 2, kPi / 2,
                                              -kPi / 2, kPi / 2, 0};
constexpr double kFlangeToTool_m = 0.14;

Eigen::Isometry3d dh_tool_pose(const JointVector& q) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 7; ++i) {
    pose = pose * Eigen::AngleAxisd(q[i], Eigen::Vector3d::UnitZ()) *
           Eigen::Translation3d(0, 0, kDh_d_m[i]) *
           Eigen::AngleAxisd(kDh_alpha_rad[i], Eigen::Vector3d::UnitX());
  }
  return pose * Eigen::Translation3d(0, 0, kFlangeToTool_m);
}

Kinematics load_model() { return Kinematics::pa10(); }

JointVector random_joints(std::mt19937& rng, const JointLimits& limits, double fraction = 1.0) {
  JointVector q;
  for (int j = 0; j < 7; ++j) {
    std::uniform_real_distribution<double> dist(limits.lower_rad[j] * fraction,
                                                limits.upper_rad[j] * fraction);
    q[j] = dist(rng);
  }
  return q;
}

// A pose well away from every singularity and limit: elbow bent, wrist bent.
JointVector general_pose() {
  JointVector q;
  q << 0.3, 0.5, -0.4, 1.3, 0.6, 0.9, -0.5;
  return q;
}

std::filesystem::path write_temp_file(const std::string& name, const std::string& text) {
  const std::filesystem::path path = std::filesystem::path(testing::TempDir()) / name;
  std::ofstream(path) << text;
  return path;
}

// ---- a model written inline -----------------------------------------------------------------

// Seven joints about z, 0.1 m apart, the tool 0.05 m above the last, turned half about x
// (pointing down); joint 4 turns about y instead, 0.2 m up the chain.
std::string tower_urdf() {
  std::vector<rtm_test::UrdfJoint> joints(7, {.xyz = {0, 0, 0.1}, .velocity_rad_s = 2});
  joints[3].axis = {0, 1, 0};
  joints[3].lower_rad = -0.5;
  return rtm_test::serial_chain_urdf(joints, {0, 0, 0.05}, {kPi, 0, 0});
}

TEST(InlineModel, TheToolPoseOfAChainWrittenInlineIsWhatItsOffsetsSay) {
  Kinematics k = Kinematics::from_urdf_string(tower_urdf(), "tower.urdf");
  EXPECT_EQ(k.source(), "tower.urdf");
  EXPECT_DOUBLE_EQ(k.limits().lower_rad[3], -0.5);
  EXPECT_DOUBLE_EQ(k.limits().velocity_rad_s[0], 2.0);
  const Eigen::Isometry3d zero = k.tool_pose(JointVector::Zero());
  EXPECT_TRUE(zero.translation().isApprox(Eigen::Vector3d(0, 0, 0.75), 1e-12)) << zero.translation().transpose();
  EXPECT_TRUE((zero.linear() * Eigen::Vector3d::UnitZ()).isApprox(-Eigen::Vector3d::UnitZ(), 1e-12))
      << "the tool points down";
  // Joint 4 (at 0.4 m, about y) tipped a quarter turn: the 0.35 m above it lie along +x.
  JointVector q = JointVector::Zero();
  q[3] = kPi / 2;
  const Eigen::Isometry3d tipped = k.tool_pose(q);
  EXPECT_TRUE(tipped.translation().isApprox(Eigen::Vector3d(0.35, 0, 0.4), 1e-12)) << tipped.translation().transpose();
  // Joint 1 (about z) a quarter turn more: that arm now lies along +y.
  q[0] = kPi / 2;
  EXPECT_TRUE(k.tool_pose(q).translation().isApprox(Eigen::Vector3d(0, 0.35, 0.4), 1e-12))
      << k.tool_pose(q).translation().transpose();
}

// ---- the model -----------------------------------------------------------------------------

TEST(Pa10Model, UrdfLoadsIntoASevenJointChainNamedS1ToW2) {
  Kinematics kinematics = load_model();
  EXPECT_EQ(kinematics.chain().getNrOfJoints(), 7u);
  // 7 moving links + F/T sensor + tool0.
  EXPECT_EQ(kinematics.chain().getNrOfSegments(), 9u);
  const std::array<std::string, 7> expected{"s1", "s2", "s3", "e1", "e2", "w1", "w2"};
  EXPECT_EQ(kinematics.limits().names, expected);
}

TEST(Pa10Model, JointLimitsComeFromTheUrdf) {
  Kinematics kinematics = load_model();
  const JointLimits& limits = kinematics.limits();
  const std::array<double, 7> position_deg{177, 91, 174, 137, 255, 165, 255};
  const std::array<double, 7> velocity_rad_s{1, 1, 1, 2, 2, 2 * kPi, 2 * kPi};
  for (int j = 0; j < 7; ++j) {
    EXPECT_NEAR(limits.upper_rad[j], position_deg[j] * kDeg, 1e-12) << limits.names[j];
    EXPECT_NEAR(limits.lower_rad[j], -position_deg[j] * kDeg, 1e-12) << limits.names[j];
    EXPECT_NEAR(limits.velocity_rad_s[j], velocity_rad_s[j], 1e-12) << limits.names[j];
  }
}

TEST(Pa10Model, ToolIsStraightAbove1457mmAtZeroJoints) {
  Kinematics kinematics = load_model();
  const Eigen::Isometry3d pose = kinematics.tool_pose(JointVector::Zero());
  EXPECT_NEAR(pose.translation().x(), 0, 1e-12);
  EXPECT_NEAR(pose.translation().y(), 0, 1e-12);
  EXPECT_NEAR(pose.translation().z(), 0.317 + 0.450 + 0.480 + 0.070 + 0.14, 1e-12);
  EXPECT_TRUE(pose.linear().isApprox(Eigen::Matrix3d::Identity(), 1e-12));
}

TEST(Pa10Model, ForwardKinematicsMatchesAnIndependentDhProduct) {
  Kinematics kinematics = load_model();
  std::mt19937 rng(20041);
  for (int sample = 0; sample < 500; ++sample) {
    const JointVector q = random_joints(rng, kinematics.limits());
    const Eigen::Isometry3d kdl = kinematics.tool_pose(q);
    const Eigen::Isometry3d dh = dh_tool_pose(q);
    ASSERT_LE((kdl.translation() - dh.translation()).norm(), 1e-12) << q.transpose();
    ASSERT_LE((kdl.linear() - dh.linear()).norm(), 1e-12) << q.transpose();
  }
}

// ---- the pose as six numbers ------------------------------------------------------------------

TEST(PoseVector, IsThePositionThenTheRotationsAxisTimesItsAngle) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() << 0.5, -0.25, 1.125;
  EXPECT_EQ(pose_vector(pose), (std::array<double, 6>{0.5, -0.25, 1.125, 0, 0, 0})) << "no rotation: zero";
  pose.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  std::array<double, 6> v = pose_vector(pose);
  EXPECT_NEAR(v[3], 0, 1e-12);
  EXPECT_NEAR(v[4], 0, 1e-12);
  EXPECT_NEAR(v[5], 0.7, 1e-12);
  pose.linear() = Eigen::AngleAxisd(-1.2, Eigen::Vector3d::UnitY()).toRotationMatrix();
  v = pose_vector(pose);
  EXPECT_NEAR(v[4], -1.2, 1e-12) << "the angle in [0, pi], the axis turned instead";
  // A half turn: the axis up to its sign, the angle pi.
  pose.linear() = Eigen::AngleAxisd(kPi, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix();
  v = pose_vector(pose);
  EXPECT_NEAR(Eigen::Vector3d(v[3], v[4], v[5]).norm(), kPi, 1e-12);
  EXPECT_NEAR(std::abs(v[3]), kPi / std::sqrt(2.0), 1e-7);
  EXPECT_NEAR(std::abs(v[4]), kPi / std::sqrt(2.0), 1e-7);
}

TEST(PoseVector, TurnedBackIntoAMatrixItIsThePosesRotationForTheArmsPoses) {
  Kinematics kinematics = load_model();
  std::mt19937 rng(2004);
  for (int sample = 0; sample < 500; ++sample) {
    const JointVector q = random_joints(rng, kinematics.limits());
    const Eigen::Isometry3d pose = kinematics.tool_pose(q);
    const std::array<double, 6> v = pose_vector(pose);
    const Eigen::Vector3d r(v[3], v[4], v[5]);
    ASSERT_LE(r.norm(), kPi + 1e-12);
    const Eigen::Matrix3d back =
        r.norm() == 0 ? Eigen::Matrix3d::Identity() : Eigen::AngleAxisd(r.norm(), r.normalized()).toRotationMatrix();
    ASSERT_LE((back - pose.linear()).norm(), 1e-12) << q.transpose();
    ASSERT_EQ(Eigen::Vector3d(v[0], v[1], v[2]), pose.translation());
  }
}

TEST(Pa10Model, JacobianMatchesFiniteDifferencesOfTheToolPose) {
  Kinematics kinematics = load_model();
  const JointVector q = general_pose();
  const Jacobian jacobian = kinematics.jacobian(q);
  const Eigen::Isometry3d pose = kinematics.tool_pose(q);
  const double step = 1e-7;
  for (int j = 0; j < 7; ++j) {
    JointVector moved = q;
    moved[j] += step;
    const Eigen::Isometry3d next = kinematics.tool_pose(moved);
    const Eigen::Vector3d linear = (next.translation() - pose.translation()) / step;
    const Eigen::AngleAxisd rotation(next.linear() * pose.linear().transpose());
    const Eigen::Vector3d angular = rotation.axis() * rotation.angle() / step;
    EXPECT_LE((jacobian.col(j).head<3>() - linear).norm(), 1e-6) << "joint " << j;
    EXPECT_LE((jacobian.col(j).tail<3>() - angular).norm(), 1e-6) << "joint " << j;
  }
}

TEST(Pa10Model, MovedModelStillComputesTheSamePoses) {
  Kinematics original = load_model();
  const Eigen::Isometry3d before = original.tool_pose(general_pose());
  Kinematics moved = std::move(original);
  EXPECT_TRUE(moved.tool_pose(general_pose()).isApprox(before, 1e-15));
  VelocityIk ik(moved);
  EXPECT_EQ(ik.solve(Twist::Constant(0.01), general_pose(), kDt_s).status, IkStatus::ok);
}

// ---- the built-in model and a file overriding it -------------------------------------------

TEST(Pa10Model, TheLibraryHasThePa10BuiltIn) {
  const Kinematics kinematics = Kinematics::pa10();
  EXPECT_EQ(kinematics.source(), "pa10.urdf (built in)");
  EXPECT_NE(builtin_pa10_urdf().find("<robot"), std::string_view::npos);
  EXPECT_EQ(kinematics.limits().names[0], "s1");
  EXPECT_EQ(kinematics.limits().names[6], "w2");
  EXPECT_EQ(Kinematics::pa10("").source(), kinematics.source()) << "an empty path means the built-in model";
}

TEST(Pa10Model, AUrdfFileOverridesTheBuiltInModel) {
  // The built-in model with the S1 velocity limit changed, as a file (what --urdf FILE loads).
  std::string urdf(builtin_pa10_urdf());
  const std::string s1_limit = R"(upper="3.0892327760299634" velocity="1.0")";
  const std::size_t at = urdf.find(s1_limit);
  ASSERT_NE(at, std::string::npos);
  urdf.replace(at, s1_limit.size(), R"(upper="3.0892327760299634" velocity="0.5")");
  const auto path = write_temp_file("slow_s1_pa10.urdf", urdf);
  const Kinematics kinematics = Kinematics::pa10(path.string());
  EXPECT_EQ(kinematics.source(), path.string());
  EXPECT_DOUBLE_EQ(kinematics.limits().velocity_rad_s[0], 0.5);
  EXPECT_DOUBLE_EQ(Kinematics::pa10().limits().velocity_rad_s[0], 1.0);
}

// ---- model errors --------------------------------------------------------------------------

TEST(Pa10ModelErrors, MalformedUrdfFileGivesAnErrorNamingTheFile) {
  const auto path = write_temp_file("malformed_pa10.urdf", "<robot name=\"x\"><link name=");
  try {
    Kinematics::from_urdf_file(path.string());
    FAIL() << "expected ModelError";
  } catch (const ModelError& error) {
    EXPECT_NE(std::string(error.what()).find(path.string()), std::string::npos) << error.what();
  }
}

TEST(Pa10ModelErrors, MissingFileGivesAnErrorNamingTheFile) {
  const std::string path = "/nonexistent/dir/pa10.urdf";
  try {
    Kinematics::from_urdf_file(path);
    FAIL() << "expected ModelError";
  } catch (const ModelError& error) {
    EXPECT_NE(std::string(error.what()).find(path), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("cannot open"), std::string::npos) << error.what();
  }
}

TEST(Pa10ModelErrors, ChainWithoutSevenRevoluteJointsIsRejected) {
  const std::string two_joints = rtm_test::serial_chain_urdf({{}, {.axis = {0, 1, 0}}});
  try {
    Kinematics::from_urdf_string(two_joints, "short.urdf");
    FAIL() << "expected ModelError";
  } catch (const ModelError& error) {
    EXPECT_NE(std::string(error.what()).find("short.urdf"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("found 2"), std::string::npos) << error.what();
  }
}

TEST(Pa10ModelErrors, MissingTipLinkIsNamed) {
  const std::string urdf(builtin_pa10_urdf());
  EXPECT_THROW(
      {
        try {
          Kinematics::from_urdf_string(urdf, "pa10.urdf", "base_link", "gripper");
        } catch (const ModelError& error) {
          EXPECT_NE(std::string(error.what()).find("'gripper'"), std::string::npos);
          throw;
        }
      },
      ModelError);
}

// ---- velocity IK ---------------------------------------------------------------------------

TEST(Pa10VelocityIk, ReproducesTheTwistFarFromSingularities) {
  Kinematics kinematics = load_model();
  VelocityIk ik(kinematics);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> component(-0.05, 0.05);
  const JointVector q = general_pose();
  for (int sample = 0; sample < 50; ++sample) {
    Twist twist;
    for (int i = 0; i < 6; ++i) twist[i] = component(rng);
    const VelocityIkResult result = ik.solve(twist, q, kDt_s);
    ASSERT_EQ(result.status, IkStatus::ok);
    EXPECT_FALSE(result.near_singular);
    EXPECT_DOUBLE_EQ(result.twist_scale, 1.0);
    EXPECT_EQ(result.held_joints, 0);
    EXPECT_LE((kinematics.jacobian(q) * result.qdot_rad_s - twist).norm(), 1e-9) << twist.transpose();
  }
}

TEST(Pa10VelocityIk, StaysBoundedAtTheStretchedUpSingularity) {
  Kinematics kinematics = load_model();
  VelocityIk ik(kinematics);
  const JointVector q = JointVector::Zero();  // straight up: s1, s3, e2, w2 all on one line
  for (int i = 0; i < 6; ++i) {
    Twist twist = Twist::Zero();
    twist[i] = i < 3 ? 0.1 : 0.3;  // includes +z, which the stretched arm cannot do at all
    const VelocityIkResult result = ik.solve(twist, q, kDt_s);
    ASSERT_EQ(result.status, IkStatus::ok);
    EXPECT_TRUE(result.near_singular) << "axis " << i;
    EXPECT_GT(result.damping, 0) << "axis " << i;
    EXPECT_TRUE(result.qdot_rad_s.allFinite());
    // Undamped, sigma_min = 0 would give unbounded rates; damped, the gain is at most
    // 1 / threshold per unit twist, and the limits cap each joint anyway.
    EXPECT_LE(result.qdot_rad_s.norm(), twist.norm() / ik.options().singular_threshold + 1e-9)
        << "axis " << i;
    for (int j = 0; j < 7; ++j)
      EXPECT_LE(std::abs(result.qdot_rad_s[j]), kinematics.limits().velocity_rad_s[j] + 1e-12);
  }
}

// Bent elbow, w1 = 0 and e2 = 90 deg: the wrist's remaining axes and the arm's can no longer
// make one angular direction. (w1 = 0 alone is not singular for this 7-joint arm: the other
// joints make up for the coinciding e2 and w2 axes.)
JointVector wrist_singular_pose(double w1_rad) {
  JointVector q;
  q << 0.2, 0.6, 0.1, 1.4, kPi / 2, w1_rad, 0.4;
  return q;
}

void expect_bounded_near_singularity(Kinematics& kinematics, const JointVector& q,
                                  const std::string& where) {
  VelocityIk ik(kinematics);
  Twist twist;
  twist << 0.02, -0.03, 0.01, 0.2, -0.3, 0.1;
  for (int axis = -1; axis < 6; ++axis) {  // the mixed twist, then each unit direction
    Twist command = twist;
    if (axis >= 0) {
      command.setZero();
      command[axis] = axis < 3 ? 0.1 : 0.3;
    }
    const VelocityIkResult result = ik.solve(command, q, kDt_s);
    ASSERT_EQ(result.status, IkStatus::ok);
    EXPECT_TRUE(result.near_singular) << where << ", axis " << axis;
    EXPECT_GT(result.damping, 0) << where << ", axis " << axis;
    EXPECT_TRUE(result.qdot_rad_s.allFinite());
    // The damped gain is at most 1 / threshold per unit twist (undamped it would be 1/sigma).
    EXPECT_LE(result.qdot_rad_s.norm(), command.norm() / ik.options().singular_threshold + 1e-9)
        << where << ", axis " << axis;
    for (int j = 0; j < 7; ++j)
      EXPECT_LE(std::abs(result.qdot_rad_s[j]), kinematics.limits().velocity_rad_s[j] + 1e-12);
  }
}

TEST(Pa10VelocityIk, StaysBoundedAtTheWristSingularity) {
  Kinematics kinematics = load_model();
  for (double w1 : {0.0, 1e-6, 1e-3})
    expect_bounded_near_singularity(kinematics, wrist_singular_pose(w1), "w1 = " + std::to_string(w1));
}

TEST(Pa10VelocityIk, StaysBoundedWithTheElbowStretched) {
  Kinematics kinematics = load_model();
  JointVector q;
  q << 0.2, 0.6, 0.1, 0.0, 0.3, 0.5, 0.4;  // e1 = 0: the wrist cannot move along the arm
  expect_bounded_near_singularity(kinematics, q, "e1 = 0");
}

TEST(Pa10VelocityIk, DampingGrowsAsTheSmallestSingularValueFalls) {
  Kinematics kinematics = load_model();
  VelocityIk ik(kinematics);
  Twist twist;
  twist << 0.0, 0.0, 0.0, 0.05, 0.0, 0.0;
  double previous_sigma = 1e9;
  double previous_damping = -1;
  for (double w1 : {0.5, 0.05, 0.02, 0.01, 0.0}) {
    const VelocityIkResult result = ik.solve(twist, wrist_singular_pose(w1), kDt_s);
    EXPECT_LT(result.min_singular_value, previous_sigma) << "w1 = " << w1;
    EXPECT_GE(result.damping, previous_damping) << "w1 = " << w1;
    previous_sigma = result.min_singular_value;
    previous_damping = result.damping;
  }
  EXPECT_NEAR(previous_damping, ik.options().max_damping, 1e-6);
}

TEST(Pa10VelocityIk, VelocityLimitScalesTheWholeTwistKeepingItsDirection) {
  Kinematics kinematics = load_model();
  VelocityIk ik(kinematics);
  const JointVector q = general_pose();
  Twist twist;
  twist << 0.8, -0.5, 0.6, 1.5, -2.0, 1.0;  // far beyond what the joints can do
  const VelocityIkResult result = ik.solve(twist, q, kDt_s);
  ASSERT_EQ(result.status, IkStatus::ok);
  EXPECT_GT(result.twist_scale, 0);
  EXPECT_LT(result.twist_scale, 1);
  const JointVector& qdot = result.qdot_rad_s;
  bool some_joint_at_its_limit = false;
  for (int j = 0; j < 7; ++j) {
    const double limit = kinematics.limits().velocity_rad_s[j];
    EXPECT_LE(std::abs(qdot[j]), limit + 1e-12) << "joint " << j;
    some_joint_at_its_limit |= std::abs(std::abs(qdot[j]) - limit) < 1e-9;
  }
  EXPECT_TRUE(some_joint_at_its_limit) << "the scale is larger than needed";
  // Clipping joints one by one would bend the tool's motion; one scale keeps it.
  const Twist achieved = kinematics.jacobian(q) * qdot;
  EXPECT_LE((achieved - result.twist_scale * twist).norm(), 1e-9);
  EXPECT_NEAR(achieved.normalized().dot(twist.normalized()), 1.0, 1e-12);
}

// s3 is the arm's redundant joint: with it held the other six still span every twist. (Holding
// e1 would not do: it alone sets the shoulder-wrist distance, so that case is stopped whole.)
TEST(Pa10VelocityIk, JointAtItsLimitIsHeldAndTheOthersStillRealiseTheTwist) {
  Kinematics kinematics = load_model();
  VelocityIk ik(kinematics);
  const int s3 = 2;
  JointVector q = general_pose();
  q[s3] = kinematics.limits().upper_rad[s3] - 1e-4;  // inside the margin already
  // The tool motion s3 alone would make, pushing s3 into its limit.
  const Twist into_limit = kinematics.jacobian(q).col(s3) * 0.2;
  const VelocityIkResult into = ik.solve(into_limit, q, kDt_s);
  ASSERT_EQ(into.status, IkStatus::ok);
  EXPECT_EQ(into.held_joints, 1u << s3);
  EXPECT_EQ(into.qdot_rad_s[s3], 0.0);
  EXPECT_LE(q[s3] + into.qdot_rad_s[s3] * kDt_s, kinematics.limits().upper_rad[s3]);
  EXPECT_LE((kinematics.jacobian(q) * into.qdot_rad_s - into.twist_scale * into_limit).norm(),
            1e-6);

  const VelocityIkResult away = ik.solve(-into_limit, q, kDt_s);
  ASSERT_EQ(away.status, IkStatus::ok);
  EXPECT_EQ(away.held_joints, 0);
  EXPECT_DOUBLE_EQ(away.twist_scale, 1.0);
  EXPECT_LT(away.qdot_rad_s[s3], 0) << "moving away from the limit is allowed";
}

TEST(Pa10VelocityIk, TwistThatCannotAvoidTheLimitsIsStoppedWholeButMotionAwayIsAllowed) {
  Kinematics kinematics = load_model();
  VelocityIk ik(kinematics);
  const JointLimits& limits = kinematics.limits();
  JointVector q = general_pose();
  // Three joints at their upper limits: the other four cannot make a general twist.
  for (int j : {0, 3, 5}) q[j] = limits.upper_rad[j];
  const Jacobian jacobian = kinematics.jacobian(q);
  const Twist into_limits = (jacobian.col(0) + jacobian.col(3) + jacobian.col(5)) * 0.1;
  const VelocityIkResult into = ik.solve(into_limits, q, kDt_s);
  ASSERT_EQ(into.status, IkStatus::ok);
  EXPECT_EQ(into.twist_scale, 0.0);
  EXPECT_EQ(into.qdot_rad_s, JointVector::Zero());

  const VelocityIkResult away = ik.solve(-into_limits, q, kDt_s);
  ASSERT_EQ(away.status, IkStatus::ok);
  EXPECT_GT(away.twist_scale, 0.0);
  for (int j = 0; j < 7; ++j)
    EXPECT_LE(q[j] + away.qdot_rad_s[j] * kDt_s, limits.upper_rad[j] + 1e-12) << "joint " << j;
  EXPECT_GT((jacobian * away.qdot_rad_s).dot(-into_limits), 0);
}

TEST(Pa10VelocityIk, NoJointEverCrossesItsLimitOverManyRandomCommands) {
  Kinematics kinematics = load_model();
  VelocityIk ik(kinematics);
  const JointLimits& limits = kinematics.limits();
  std::mt19937 rng(99);
  std::uniform_real_distribution<double> component(-0.5, 0.5);
  for (int sample = 0; sample < 300; ++sample) {
    JointVector q = random_joints(rng, limits);
    const int pinned = sample % 7;  // one joint on a limit each time
    q[pinned] = sample % 2 ? limits.upper_rad[pinned] : limits.lower_rad[pinned];
    Twist twist;
    for (int i = 0; i < 6; ++i) twist[i] = component(rng);
    const VelocityIkResult result = ik.solve(twist, q, kDt_s);
    ASSERT_EQ(result.status, IkStatus::ok);
    for (int j = 0; j < 7; ++j) {
      const double next = q[j] + result.qdot_rad_s[j] * kDt_s;
      ASSERT_LE(next, std::max(q[j], limits.upper_rad[j]) + 1e-12) << "sample " << sample;
      ASSERT_GE(next, std::min(q[j], limits.lower_rad[j]) - 1e-12) << "sample " << sample;
      ASSERT_LE(std::abs(result.qdot_rad_s[j]), limits.velocity_rad_s[j] + 1e-12);
    }
  }
}

TEST(Pa10VelocityIk, NanOrInfInputIsAnErrorAndCommandsNoMotion) {
  Kinematics kinematics = load_model();
  VelocityIk ik(kinematics);
  Twist twist = Twist::Constant(0.01);
  twist[4] = std::numeric_limits<double>::quiet_NaN();
  VelocityIkResult result = ik.solve(twist, general_pose(), kDt_s);
  EXPECT_EQ(result.status, IkStatus::invalid_input);
  EXPECT_NE(std::string(result.error).find("NaN"), std::string::npos);
  EXPECT_EQ(result.qdot_rad_s, JointVector::Zero());

  JointVector q = general_pose();
  q[2] = std::numeric_limits<double>::infinity();
  result = ik.solve(Twist::Constant(0.01), q, kDt_s);
  EXPECT_EQ(result.status, IkStatus::invalid_input);
  EXPECT_NE(std::string(result.error).find("joint positions"), std::string::npos);
  EXPECT_EQ(result.qdot_rad_s, JointVector::Zero());

  result = ik.solve(Twist::Constant(0.01), general_pose(), 0.0);
  EXPECT_EQ(result.status, IkStatus::invalid_input);
  EXPECT_NE(std::string(result.error).find("dt"), std::string::npos);
}

TEST(Pa10VelocityIk, SolveAllocatesNothing) {
  Kinematics kinematics = load_model();
  VelocityIk ik(kinematics);
  const JointLimits& limits = kinematics.limits();
  JointVector at_limit = general_pose();
  at_limit[3] = limits.upper_rad[3];
  Twist twist;
  twist << 0.05, 0.02, -0.03, 0.1, 0.0, 0.2;
  ik.solve(twist, general_pose(), kDt_s);  // warm up anything lazily initialised
  const auto before = rtm_test::allocations_on_this_thread();
  double sink = 0;
  for (int i = 0; i < 100; ++i) {
    sink += ik.solve(twist, general_pose(), kDt_s).qdot_rad_s[0];         // free solve
    sink += ik.solve(twist * 20, general_pose(), kDt_s).qdot_rad_s[0];    // velocity scaling
    sink += ik.solve(twist, JointVector::Zero(), kDt_s).qdot_rad_s[0];   // singular
    sink += ik.solve(kinematics.jacobian(at_limit).col(3), at_limit, kDt_s).qdot_rad_s[0];
    sink += kinematics.tool_pose(general_pose()).translation().x();
  }
  EXPECT_EQ(rtm_test::allocations_on_this_thread() - before, 0u);
  EXPECT_TRUE(std::isfinite(sink));
}

}  // namespace
}  // namespace rtm::pa10
