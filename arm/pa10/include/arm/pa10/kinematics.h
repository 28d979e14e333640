// SPDX-License-Identifier: Apache-2.0
// PA10-7C kinematics: the URDF turned into a KDL chain, forward kinematics, the Jacobian and
// a damped-least-squares velocity IK that respects joint position and velocity limits.
//
// The URDF (arm/pa10/models/pa10.urdf, built into the library: Kinematics::pa10()) is the single
// source of truth: joint limits are read from it, never restated in code. Nothing here knows
// about CAN or CORBA.
//
// Conventions used everywhere in rtm::pa10:
//   joint order   s1 s2 s3 e1 e2 w1 w2 (index 0..6), angles in rad, rates in rad/s
//   twist         (vx, vy, vz [m/s], wx, wy, wz [rad/s]) in the base frame (base_link),
//                 linear part taken at the tool0 point
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <array>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>

namespace KDL {
class Chain;
class ChainFkSolverPos_recursive;
class ChainJntToJacSolver;
class JntArray;
class Jacobian;
}  // namespace KDL

namespace rtm::pa10 {

// ---------------------------------------------------------------- types

inline constexpr int kJointCount = 7;

using JointVector = Eigen::Matrix<double, kJointCount, 1>;  // one value per joint, s1..w2
using Twist = Eigen::Matrix<double, 6, 1>;                  // (v m/s, w rad/s), base frame
using Jacobian = Eigen::Matrix<double, 6, kJointCount>;     // base frame, ref. point tool0

// Raised when a URDF cannot be read or does not describe a 7-revolute-joint chain from the
// base link to the tip link. what() names the file (or the source name given for a string).
class ModelError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Per-joint limits as read from the URDF <limit> elements.
struct JointLimits {
  std::array<std::string, kJointCount> names;  // URDF joint names, chain order
  JointVector lower_rad;                       // position lower limit
  JointVector upper_rad;                       // position upper limit
  JointVector velocity_rad_s;                  // |qdot| limit (> 0)
};

// ---------------------------------------------------------------- kinematic model

// The chain base_link -> tool0 (by default) built from a URDF with urdfdom (no kdl_parser,
// which pulls ROS in on Debian). Fixed joints become KDL segments without a joint.
// Not thread-safe: tool_pose()/jacobian() use pre-allocated scratch. Movable, not copyable.
// The PA10-7C model built into this library: arm/pa10/models/pa10.urdf, embedded at build time.
std::string_view builtin_pa10_urdf();

class Kinematics {
 public:
  // The PA10-7C: the built-in model (builtin_pa10_urdf(), source name "pa10.urdf (built in)"),
  // or the URDF file `urdf_path` when it is not empty (a --urdf override). Throws ModelError.
  static Kinematics pa10(const std::string& urdf_path = "");
  // Loads the URDF file at `urdf_path`. Throws ModelError naming the file on any problem.
  static Kinematics from_urdf_file(const std::string& urdf_path,
                                 const std::string& base_link = "base_link",
                                 const std::string& tip_link = "tool0");
  // Same from URDF text; `source_name` stands for the file name in error messages.
  static Kinematics from_urdf_string(const std::string& urdf_xml, const std::string& source_name,
                                   const std::string& base_link = "base_link",
                                   const std::string& tip_link = "tool0");

  Kinematics(Kinematics&&) noexcept;
  Kinematics& operator=(Kinematics&&) noexcept;
  Kinematics(const Kinematics&) = delete;
  Kinematics& operator=(const Kinematics&) = delete;
  ~Kinematics();

  const KDL::Chain& chain() const { return *chain_; }
  const JointLimits& limits() const { return limits_; }
  const std::string& source() const { return source_; }  // file name (for messages)

  // Pose of the tip link (tool0) in the base frame. Allocates nothing.
  Eigen::Isometry3d tool_pose(const JointVector& q_rad);
  // Geometric Jacobian: columns map qdot to the tool0 twist in the base frame. Allocates
  // nothing.
  Jacobian jacobian(const JointVector& q_rad);

 private:
  Kinematics(std::unique_ptr<KDL::Chain> chain, JointLimits limits, std::string source);

  std::unique_ptr<KDL::Chain> chain_;
  JointLimits limits_;
  std::string source_;
  std::unique_ptr<KDL::ChainFkSolverPos_recursive> fk_solver_;
  std::unique_ptr<KDL::ChainJntToJacSolver> jac_solver_;
  std::unique_ptr<KDL::JntArray> q_scratch_;
  std::unique_ptr<KDL::Jacobian> jac_scratch_;
};

// A pose as six numbers: the position x y z (m), then the orientation as a rotation vector
// rx ry rz (the rotation's axis times its angle, rad, the angle in [0, pi]), both in the frame
// the pose is given in (for tool_pose(): the base frame). Allocates nothing.
std::array<double, 6> pose_vector(const Eigen::Isometry3d& pose);

// ---------------------------------------------------------------- velocity IK

struct VelocityIkOptions {
  // Below this smallest singular value of J the solve damps (units of J: m/rad and 1).
  double singular_threshold = 0.04;
  // Damping factor reached when the smallest singular value is 0 (lambda grows smoothly as
  // sigma_min falls below the threshold: lambda^2 = max^2 * (1 - (sigma_min/threshold)^2)).
  double max_damping = 0.04;
  // A joint is held (its column removed) when its commanded motion would carry it closer than
  // this to a position limit within dt; keeps a small margin from the hard limit.
  double position_margin_rad = 1e-3;
  // Holding joints changes the solution; it is kept only when J*qdot stays within this
  // relative error of the commanded twist, else the whole twist is scaled instead.
  double held_joint_tolerance = 1e-3;
};

enum class IkStatus : std::uint8_t {
  ok,             // qdot realises scale * twist (within damping near singularities)
  invalid_input,  // NaN/inf in the twist or q, or dt <= 0: qdot is zero, see error
};

struct VelocityIkResult {
  JointVector qdot_rad_s = JointVector::Zero();  // joint rates to command
  IkStatus status = IkStatus::ok;
  const char* error = "";        // static text when status != ok (never allocated)
  double twist_scale = 1.0;      // in [0, 1]: the whole twist was multiplied by this
  bool near_singular = false;    // smallest singular value below the threshold
  double min_singular_value = 0; // of the Jacobian at q (after holding joints, if any)
  double damping = 0;            // lambda used
  std::uint8_t held_joints = 0;  // bit j set: joint j held still at its position limit
};

// Damped-least-squares velocity IK with limits, on a fixed-size SVD (Eigen). The limits
// are handled without bending the twist's direction:
//   1. joints whose motion would cross a position limit within dt are held and the twist is
//      re-solved with the others (the arm is redundant), as long as the result still realises
//      the twist; otherwise the whole twist is scaled so that no joint crosses its limit
//      (scale 0 when a joint at its limit would be pushed further);
//   2. the whole twist is scaled (never joint by joint) so every |qdot| is within its
//      velocity limit.
// solve() allocates nothing: all solvers and buffers are created in the constructor.
// Not thread-safe (one instance per control thread).
class VelocityIk {
 public:
  // `kinematics` must outlive this object.
  explicit VelocityIk(Kinematics& kinematics, VelocityIkOptions options = {});

  // twist_base: commanded tool0 twist (base frame); q_rad: current joint positions;
  // dt_s: how long the returned rates will be applied (the control period).
  VelocityIkResult solve(const Twist& twist_base, const JointVector& q_rad, double dt_s);

  const VelocityIkOptions& options() const { return options_; }

 private:
  // DLS solve with the columns in `held` removed; fills result's damping/singular fields.
  JointVector damped_solve(const Jacobian& jacobian, const Twist& twist, std::uint8_t held,
                          VelocityIkResult& result) const;

  Kinematics& kinematics_;
  VelocityIkOptions options_;
};

}  // namespace rtm::pa10
