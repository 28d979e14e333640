// SPDX-License-Identifier: Apache-2.0
#include "arm/pa10/kinematics.h"

#include <Eigen/SVD>
#include <kdl/chain.hpp>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainjnttojacsolver.hpp>
#include <kdl/frames.hpp>
#include <kdl/jacobian.hpp>
#include <kdl/jntarray.hpp>
#include <kdl/rigidbodyinertia.hpp>
#include <kdl/rotationalinertia.hpp>
#include <kdl/segment.hpp>
#include <urdf_model/model.h>
#include <urdf_parser/urdf_parser.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <vector>

namespace rtm::pa10 {
namespace {

[[noreturn]] void fail(const std::string& source, const std::string& what) {
  throw ModelError(source + ": " + what);
}

KDL::Frame to_kdl(const urdf::Pose& pose) {
  const urdf::Rotation& r = pose.rotation;
  return KDL::Frame(KDL::Rotation::Quaternion(r.x, r.y, r.z, r.w),
                    KDL::Vector(pose.position.x, pose.position.y, pose.position.z));
}

// Inertia of the link about its centre of mass, expressed in the link frame (URDF gives it in
// the <inertial> origin frame, which may be rotated).
KDL::RigidBodyInertia to_kdl(const urdf::InertialSharedPtr& inertial) {
  if (!inertial) return KDL::RigidBodyInertia::Zero();
  const KDL::Frame origin = to_kdl(inertial->origin);
  Eigen::Matrix3d in_origin_frame;
  in_origin_frame << inertial->ixx, inertial->ixy, inertial->ixz,  //
      inertial->ixy, inertial->iyy, inertial->iyz,                 //
      inertial->ixz, inertial->iyz, inertial->izz;
  Eigen::Matrix3d rotation;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) rotation(r, c) = origin.M(r, c);
  const Eigen::Matrix3d in_link_frame = rotation * in_origin_frame * rotation.transpose();
  const KDL::RotationalInertia about_com(in_link_frame(0, 0), in_link_frame(1, 1),
                                         in_link_frame(2, 2), in_link_frame(0, 1),
                                         in_link_frame(0, 2), in_link_frame(1, 2));
  return KDL::RigidBodyInertia(inertial->mass, origin.p, about_com);
}

const char* type_name(int urdf_type) {
  switch (urdf_type) {
    case urdf::Joint::REVOLUTE: return "revolute";
    case urdf::Joint::CONTINUOUS: return "continuous";
    case urdf::Joint::PRISMATIC: return "prismatic";
    case urdf::Joint::FLOATING: return "floating";
    case urdf::Joint::PLANAR: return "planar";
    case urdf::Joint::FIXED: return "fixed";
    default: return "unknown";
  }
}

}  // namespace

// ---------------------------------------------------------------- Kinematics

Kinematics Kinematics::pa10(const std::string& urdf_path) {
  if (!urdf_path.empty()) return from_urdf_file(urdf_path);
  return from_urdf_string(std::string(builtin_pa10_urdf()), "pa10.urdf (built in)");
}

Kinematics Kinematics::from_urdf_file(const std::string& urdf_path, const std::string& base_link,
                                    const std::string& tip_link) {
  std::ifstream file(urdf_path);
  if (!file) fail(urdf_path, "cannot open the URDF file");
  std::ostringstream text;
  text << file.rdbuf();
  return from_urdf_string(text.str(), urdf_path, base_link, tip_link);
}

Kinematics Kinematics::from_urdf_string(const std::string& urdf_xml, const std::string& source_name,
                                      const std::string& base_link, const std::string& tip_link) {
  const urdf::ModelInterfaceSharedPtr model = urdf::parseURDF(urdf_xml);
  if (!model) fail(source_name, "not a valid URDF (urdfdom could not parse it)");
  if (!model->getLink(base_link)) fail(source_name, "no link named '" + base_link + "'");
  urdf::LinkConstSharedPtr tip = model->getLink(tip_link);
  if (!tip) fail(source_name, "no link named '" + tip_link + "'");

  // Walk from the tip up to the base, then build the chain base -> tip.
  std::vector<urdf::LinkConstSharedPtr> path;
  for (urdf::LinkConstSharedPtr link = tip; link->name != base_link;) {
    path.push_back(link);
    urdf::LinkConstSharedPtr parent = link->getParent();
    if (!parent || !link->parent_joint)
      fail(source_name, "link '" + tip_link + "' is not below link '" + base_link + "'");
    link = parent;
  }
  std::reverse(path.begin(), path.end());

  auto chain = std::make_unique<KDL::Chain>();
  JointLimits limits;
  int joint_index = 0;
  for (const urdf::LinkConstSharedPtr& link : path) {
    const urdf::JointSharedPtr& joint = link->parent_joint;
    const KDL::Frame origin = to_kdl(joint->parent_to_joint_origin_transform);
    KDL::Joint kdl_joint(joint->name, KDL::Joint::Fixed);
    if (joint->type == urdf::Joint::REVOLUTE) {
      if (joint_index >= kJointCount)
        fail(source_name, "more than " + std::to_string(kJointCount) + " revolute joints between '" +
                              base_link + "' and '" + tip_link + "'");
      const urdf::Vector3& a = joint->axis;
      const KDL::Vector axis(a.x, a.y, a.z);
      if (axis.Norm() < 1e-9) fail(source_name, "joint '" + joint->name + "' has a zero axis");
      const urdf::JointLimitsSharedPtr& limit = joint->limits;
      if (!limit) fail(source_name, "joint '" + joint->name + "' has no <limit>");
      if (!(limit->lower < limit->upper))
        fail(source_name, "joint '" + joint->name + "' has lower limit >= upper limit");
      if (!(limit->velocity > 0))
        fail(source_name, "joint '" + joint->name + "' has no positive velocity limit");
      limits.names[joint_index] = joint->name;
      limits.lower_rad[joint_index] = limit->lower;
      limits.upper_rad[joint_index] = limit->upper;
      limits.velocity_rad_s[joint_index] = limit->velocity;
      ++joint_index;
      kdl_joint = KDL::Joint(joint->name, origin.p, origin.M * (axis / axis.Norm()),
                             KDL::Joint::RotAxis);
    } else if (joint->type != urdf::Joint::FIXED) {
      fail(source_name, "joint '" + joint->name + "' is " + type_name(joint->type) +
                            "; only revolute and fixed joints are supported");
    }
    chain->addSegment(KDL::Segment(link->name, kdl_joint, origin, to_kdl(link->inertial)));
  }
  if (joint_index != kJointCount)
    fail(source_name, "expected " + std::to_string(kJointCount) + " revolute joints between '" +
                          base_link + "' and '" + tip_link + "', found " +
                          std::to_string(joint_index));
  return Kinematics(std::move(chain), std::move(limits), source_name);
}

Kinematics::Kinematics(std::unique_ptr<KDL::Chain> chain, JointLimits limits, std::string source)
    : chain_(std::move(chain)),
      limits_(std::move(limits)),
      source_(std::move(source)),
      // The solvers keep a reference to *chain_, which stays put when Kinematics moves.
      fk_solver_(std::make_unique<KDL::ChainFkSolverPos_recursive>(*chain_)),
      jac_solver_(std::make_unique<KDL::ChainJntToJacSolver>(*chain_)),
      q_scratch_(std::make_unique<KDL::JntArray>(kJointCount)),
      jac_scratch_(std::make_unique<KDL::Jacobian>(kJointCount)) {}

Kinematics::Kinematics(Kinematics&&) noexcept = default;
Kinematics& Kinematics::operator=(Kinematics&&) noexcept = default;
Kinematics::~Kinematics() = default;

Eigen::Isometry3d Kinematics::tool_pose(const JointVector& q_rad) {
  q_scratch_->data = q_rad;
  KDL::Frame tool;
  fk_solver_->JntToCart(*q_scratch_, tool);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) pose.linear()(r, c) = tool.M(r, c);
    pose.translation()[r] = tool.p[r];
  }
  return pose;
}

std::array<double, 6> pose_vector(const Eigen::Isometry3d& pose) {
  // Through the unit quaternion (Eigen's AngleAxis from a rotation matrix): the angle comes
  // from atan2 of the vector part's norm and |w|, exact near 0 and pi alike.
  const Eigen::AngleAxisd rotation(pose.linear());
  const Eigen::Vector3d r = rotation.axis() * rotation.angle();
  const Eigen::Vector3d& p = pose.translation();
  return {p.x(), p.y(), p.z(), r.x(), r.y(), r.z()};
}

Jacobian Kinematics::jacobian(const JointVector& q_rad) {
  q_scratch_->data = q_rad;
  jac_solver_->JntToJac(*q_scratch_, *jac_scratch_);
  return jac_scratch_->data;
}

// ---------------------------------------------------------------- VelocityIk

VelocityIk::VelocityIk(Kinematics& kinematics, VelocityIkOptions options)
    : kinematics_(kinematics), options_(options) {}

JointVector VelocityIk::damped_solve(const Jacobian& jacobian, const Twist& twist,
                                    std::uint8_t held, VelocityIkResult& result) const {
  Jacobian reduced = jacobian;
  for (int j = 0; j < kJointCount; ++j)
    if (held & (1u << j)) reduced.col(j).setZero();

  // Fixed-size SVD: no heap allocation.
  const Eigen::JacobiSVD<Jacobian> svd(reduced, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const auto& sigma = svd.singularValues();
  const double sigma_min = sigma[sigma.size() - 1];
  double damping_sq = 0;
  if (sigma_min < options_.singular_threshold) {
    const double ratio = sigma_min / options_.singular_threshold;
    damping_sq = options_.max_damping * options_.max_damping * (1.0 - ratio * ratio);
  }
  result.min_singular_value = sigma_min;
  result.damping = std::sqrt(damping_sq);
  result.near_singular = sigma_min < options_.singular_threshold;

  const Eigen::Matrix<double, 6, 1> projected = svd.matrixU().transpose() * twist;
  JointVector qdot = JointVector::Zero();
  for (int i = 0; i < sigma.size(); ++i) {
    const double denominator = sigma[i] * sigma[i] + damping_sq;
    if (denominator <= 0) continue;  // an exactly zero direction without damping: no motion
    qdot += svd.matrixV().col(i) * (sigma[i] / denominator * projected[i]);
  }
  for (int j = 0; j < kJointCount; ++j)
    if (held & (1u << j)) qdot[j] = 0;
  return qdot;
}

VelocityIkResult VelocityIk::solve(const Twist& twist_base, const JointVector& q_rad,
                                   double dt_s) {
  VelocityIkResult result;
  if (!twist_base.allFinite()) {
    result.status = IkStatus::invalid_input;
    result.error = "velocity IK: the twist contains NaN or inf";
    result.twist_scale = 0;
    return result;
  }
  if (!q_rad.allFinite()) {
    result.status = IkStatus::invalid_input;
    result.error = "velocity IK: the joint positions contain NaN or inf";
    result.twist_scale = 0;
    return result;
  }
  if (!(dt_s > 0) || !std::isfinite(dt_s)) {
    result.status = IkStatus::invalid_input;
    result.error = "velocity IK: dt must be positive and finite";
    result.twist_scale = 0;
    return result;
  }

  const JointLimits& limits = kinematics_.limits();
  const JointVector upper = limits.upper_rad.array() - options_.position_margin_rad;
  const JointVector lower = limits.lower_rad.array() + options_.position_margin_rad;
  auto crossing = [&](const JointVector& qdot, std::uint8_t held) {
    std::uint8_t crossing_joints = 0;
    for (int j = 0; j < kJointCount; ++j) {
      if (held & (1u << j)) continue;
      const double next = q_rad[j] + qdot[j] * dt_s;
      if ((qdot[j] > 0 && next > upper[j]) || (qdot[j] < 0 && next < lower[j]))
        crossing_joints |= static_cast<std::uint8_t>(1u << j);
    }
    return crossing_joints;
  };

  const Jacobian jacobian = kinematics_.jacobian(q_rad);
  JointVector qdot = damped_solve(jacobian, twist_base, 0, result);

  // 1. Position limits: hold the joints that would cross, re-solve with the others.
  std::uint8_t held = 0;
  std::uint8_t crossing_joints = crossing(qdot, held);
  if (crossing_joints != 0) {
    const double free_residual = (jacobian * qdot - twist_base).norm();
    VelocityIkResult held_result = result;
    JointVector held_qdot = qdot;
    for (int attempt = 0; attempt < kJointCount && crossing_joints != 0; ++attempt) {
      held |= crossing_joints;
      held_qdot = damped_solve(jacobian, twist_base, held, held_result);
      crossing_joints = crossing(held_qdot, held);
    }
    const double held_residual = (jacobian * held_qdot - twist_base).norm();
    const bool realises_twist =
        held_residual <= free_residual + options_.held_joint_tolerance * twist_base.norm();
    if (crossing_joints == 0 && realises_twist) {
      qdot = held_qdot;
      result = held_result;
      result.held_joints = held;
    } else {
      held = 0;  // fall back to scaling the free solution
    }
  }

  // 2. One scale for the whole twist: position room (fallback case) and velocity limits.
  double scale = 1.0;
  for (int j = 0; j < kJointCount; ++j) {
    const double rate = std::abs(qdot[j]);
    if (rate == 0) continue;
    scale = std::min(scale, limits.velocity_rad_s[j] / rate);
    const double room = qdot[j] > 0 ? upper[j] - q_rad[j] : q_rad[j] - lower[j];
    if (rate * dt_s > room) scale = std::min(scale, std::max(0.0, room) / (rate * dt_s));
  }
  result.qdot_rad_s = qdot * scale;
  result.twist_scale = scale;
  return result;
}

}  // namespace rtm::pa10
