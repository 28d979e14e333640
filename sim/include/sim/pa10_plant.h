// SPDX-License-Identifier: Apache-2.0
// The PA10 scene in MuJoCo with the drives' joint servos: what the CAN devices stand in front.
//
// Loads sim/models/pa10_scene.xml (or another scene with the same names: joints s1..w2,
// motors s1..w2, sites wrist_ft/tool_tip/joystick_ft, body joystick_handle, sensors
// wrist_force/wrist_torque/joystick_force/joystick_torque, keyframe "ready"; optionally the
// table top's slide joint "surface" after the arm's joints, sim/surface.h) and steps it.
//
// Each joint's servo is the drive's inner loop: in velocity mode a PI loop on the velocity
// error, scaled by the joint-space inertia (computed-torque form: tau = M * a + qfrc_bias, so
// the arm does not sag and the joints do not disturb each other), in hold mode a stiff PD on
// the position where the brake engaged (the joint's velocity is zeroed at that instant: the
// brake is ideal) plus the load the velocity loop's integral carried then, so a braked joint
// that pushes on something neither yields nor jolts when released. Torques are clamped to the
// motors' ctrlrange (the URDF's effort limits).
// Stepping allocates nothing.
#pragma once

#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

#include "sim/plant.h"
#include "sim/surface.h"

struct mjModel_;
struct mjData_;
struct mjContact_;

namespace rtm::sim {

// The scene cannot be loaded or lacks a named element; what() names the file and the cause.
class SceneError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The drive's velocity loop is a PI in acceleration form, a = kv*e + ki*integral(e), with
// ki = kv^2/4 (a critically damped position error). Its closed-loop transfer from target to
// actual velocity, (kv s + ki)/(s^2 + kv s + ki), falls to -3 dB at 1.2412 kv: the bandwidth is
// given as that -3 dB frequency, as a drive's data sheet states it, and kv follows from it
// (tests/sim/identification_test.cpp measures it with a sine sweep).
//
// The bandwidth decides how a force loop closed around the arm behaves: the integral is a
// position spring of ki times the joint inertia in series with the surface. At 25 rad/s
// (kv = 20) that spring, a few hundred N/m at the tool, is what the loop feels, whatever the
// surface; at the default 400 rad/s the loop meets the surface (docs/pa10-model.md, "Drives").
struct ServoGains {
  double velocity_bandwidth_rad_s = 400;  // closed-loop -3 dB
  double hold_stiffness_1_s2 = 10000;     // brake: a = kp*(q_hold - q) - kd*qdot
  double hold_damping_1_s = 200;

  // -3 dB bandwidth of (kv s + kv^2/4)/(s^2 + kv s + kv^2/4) over kv: sqrt(3 + sqrt(10)) / 2.
  static constexpr double kBandwidthPerKv = 1.2411967672541269;
  double velocity_gain_1_s() const { return velocity_bandwidth_rad_s / kBandwidthPerKv; }
  double velocity_integral_1_s2() const {
    const double kv = velocity_gain_1_s();
    return kv * kv / 4;
  }
  // The gains the plant applies with its explicit step dt: the proportional gain whose
  // one-step decay exp(-kv dt) matches the continuous loop's, (1 - exp(-kv dt)) / dt, and
  // its integral. Without it a 1 ms step makes a 400 rad/s loop measure 25 % faster.
  double discrete_velocity_gain_1_s(double dt_s) const {
    return -std::expm1(-velocity_gain_1_s() * dt_s) / dt_s;
  }
  double discrete_velocity_integral_1_s2(double dt_s) const {
    const double kv = discrete_velocity_gain_1_s(dt_s);
    return kv * kv / 4;
  }
};

class Pa10Plant final : public Plant {
 public:
  // Loads the scene, sets the "ready" keyframe, every joint in hold, and the surface (when the
  // scene has a "surface" joint). Throws SceneError.
  explicit Pa10Plant(const std::string& scene_path, ServoGains gains = {},
                     const Surface& surface = default_surface());
  ~Pa10Plant();
  Pa10Plant(const Pa10Plant&) = delete;
  Pa10Plant& operator=(const Pa10Plant&) = delete;

  // Sets the joint vector (rad, zero velocity; holds there) and recomputes the kinematics.
  void set_joint_positions(const std::array<double, kJointCount>& q_rad);
  // Sets the named keyframe; throws SceneError if it does not exist.
  void reset_to_keyframe(const std::string& name);

  // Makes the table top this surface, at rest at its nominal height under its own weight.
  // Throws SceneError if the scene has no "surface" joint.
  void set_surface(const Surface& surface);
  const Surface& surface() const { return surface_; }
  // How far the table top is pushed down from its rest height [m].
  double surface_deflection_m() const;
  // How far the tool tip's contact point is below the table top's rest height: the surface's
  // deflection plus MuJoCo's penetration of the tip into the plate [m]; 0 when not touching.
  double tool_indentation_m() const;

  // What joint i's servo does from the next step on.
  void set_command(int joint, const JointCommand& command) override;
  // The operator's wrench on the joystick handle, taken at the joystick sensor's origin
  // (joystick frame = world frame): what the joystick then reads, less the handle's weight.
  void set_operator_wrench(const Wrench& wrench) override;

  // One physics step (timestep_s()).
  void step() override;
  // The force the tool tip pushes on the table top with, along its normal, after the last step
  // (N; 0 when not touching): what the plant's friction scales with.
  double tool_normal_force_N() const { return normal_force_N_; }

  // Below this tangential speed the tip's friction fades linearly (viscous): a Coulomb law
  // with no static stick, so that neither the explicit step nor the drives' loops chatter on it.
  static constexpr double kSlipSpeed_m_s = 0.002;

  double timestep_s() const override;
  double time_s() const;
  JointState joint_state(int joint) const override;
  // External wrench on the tool side of the wrist sensor, flange frame, untared (includes the
  // tool's weight and inertia).
  Wrench wrist_wrench() const override;
  // External wrench on the joystick handle, joystick frame, untared.
  Wrench joystick_wrench() const override;
  // Pose of the tool tip site (tool0) in the world (= arm base) frame.
  std::array<double, 3> tool_position_m() const;
  std::array<double, 9> tool_rotation() const;  // row-major
  double applied_torque_Nm(int joint) const;

  const mjModel_* model() const { return model_; }
  mjData_* data() { return data_; }

 private:
  void compute_servo_torques();

  mjModel_* model_ = nullptr;
  mjData_* data_ = nullptr;
  // The arm's seven joints, then the table top's slide joint if the scene has it.
  static constexpr int kMaxDofs = kJointCount + 1;

  ServoGains gains_;
  Surface surface_;
  int surface_joint_ = -1;  // -1: the scene has a rigid table
  std::array<JointCommand, kJointCount> commands_{};
  std::array<double, kJointCount> hold_position_rad_{};
  std::array<double, kJointCount> velocity_error_integral_rad_{};
  // The load a braked joint bears, as the acceleration term the velocity loop's integral gave
  // it when the brake engaged, less the joint damping that stopped with the joint.
  std::array<double, kJointCount> held_load_1_s2_{};
  std::array<double, kMaxDofs> scratch_torque_Nm_{};
  std::array<double, kMaxDofs> scratch_acceleration_{};
  std::array<double, kMaxDofs> desired_acceleration_{};  // scratch, rad/s^2; 0 for the surface
  std::array<double, kMaxDofs> torque_Nm_{};             // scratch
  int joystick_body_ = -1;
  int joystick_site_ = -1;
  int tool_site_ = -1;
  int tool_geom_ = -1, table_top_geom_ = -1;  // -1: not in the scene
  int tool_body_ = -1;
  double normal_force_N_ = 0;  // the tip on the top, after the last step
  // Friction of the tip on the top, applied at the tip: -mu N v_t / max(|v_t|, kSlipSpeed), v_t
  // the tip's velocity along the top; none when not touching.
  void apply_tool_friction();
  void measure_tool_normal_force();
  bool tool_on_top(const mjContact_& contact) const;  // between the tool tip and the table top
  int wrist_force_adr_ = -1, wrist_torque_adr_ = -1;
  int joystick_force_adr_ = -1, joystick_torque_adr_ = -1;
};

}  // namespace rtm::sim
