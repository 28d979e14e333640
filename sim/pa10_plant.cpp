// SPDX-License-Identifier: Apache-2.0
#include "sim/pa10_plant.h"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

namespace rtm::sim {

namespace {

constexpr const char* kJointNames[kJointCount] = {"s1", "s2", "s3", "e1", "e2", "w1", "w2"};

int require_id(const mjModel* model, mjtObj type, const char* name, const std::string& scene) {
  const int id = mj_name2id(model, type, name);
  if (id < 0) throw SceneError(scene + ": the scene has no " + mju_type2Str(type) + " '" + name + "'");
  return id;
}

// MuJoCo's force/torque sensors report what the parent body exerts on the sensor's body; the
// sensor here reports what the world exerts on the tool side, hence the sign flip.
Wrench external_wrench(const mjData* data, int force_adr, int torque_adr) {
  Wrench wrench;
  for (int i = 0; i < 3; ++i) {
    wrench.force_N[i] = -data->sensordata[force_adr + i];
    wrench.torque_Nm[i] = -data->sensordata[torque_adr + i];
  }
  return wrench;
}

}  // namespace

Pa10Plant::Pa10Plant(const std::string& scene_path, ServoGains gains, const Surface& surface)
    : gains_(gains), surface_(surface) {
  if (!std::filesystem::is_regular_file(scene_path))
    throw SceneError(scene_path + ": scene file not found");
  char error[1000] = "";
  model_ = mj_loadXML(scene_path.c_str(), nullptr, error, sizeof error);
  if (!model_) throw SceneError(scene_path + ": MuJoCo cannot load it: " + error);
  data_ = mj_makeData(model_);
  try {
    surface_joint_ = mj_name2id(model_, mjOBJ_JOINT, "surface");
    const int dofs = surface_joint_ < 0 ? kJointCount : kJointCount + 1;
    if (model_->nq != dofs || model_->nv != dofs || model_->nu != kJointCount)
      throw SceneError(scene_path +
                       ": expected 7 hinge joints, 7 motors and at most a 'surface' slide joint, "
                       "found nq=" + std::to_string(model_->nq) + " nu=" + std::to_string(model_->nu));
    if (surface_joint_ >= 0 &&
        (surface_joint_ != kJointCount || model_->jnt_type[surface_joint_] != mjJNT_SLIDE))
      throw SceneError(scene_path + ": the 'surface' joint must be a slide joint after the arm's");
    for (int j = 0; j < kJointCount; ++j) {
      // The servo indexes qpos/qvel/ctrl by joint number: the scene must keep that order.
      const int joint = require_id(model_, mjOBJ_JOINT, kJointNames[j], scene_path);
      const int motor = require_id(model_, mjOBJ_ACTUATOR, kJointNames[j], scene_path);
      if (joint != j || model_->jnt_qposadr[joint] != j || model_->jnt_dofadr[joint] != j ||
          motor != j || model_->actuator_trnid[2 * motor] != j)
        throw SceneError(scene_path + ": joint/motor '" + kJointNames[j] +
                         "' is not the scene's joint/motor number " + std::to_string(j));
    }
    joystick_body_ = require_id(model_, mjOBJ_BODY, "joystick_handle", scene_path);
    joystick_site_ = require_id(model_, mjOBJ_SITE, "joystick_ft", scene_path);
    tool_site_ = require_id(model_, mjOBJ_SITE, "tool_tip", scene_path);
    tool_geom_ = mj_name2id(model_, mjOBJ_GEOM, "tool_tip");
    tool_body_ = model_->site_bodyid[tool_site_];
    table_top_geom_ = mj_name2id(model_, mjOBJ_GEOM, "table_top");
    auto sensor_adr = [&](const char* name) {
      return model_->sensor_adr[require_id(model_, mjOBJ_SENSOR, name, scene_path)];
    };
    wrist_force_adr_ = sensor_adr("wrist_force");
    wrist_torque_adr_ = sensor_adr("wrist_torque");
    joystick_force_adr_ = sensor_adr("joystick_force");
    joystick_torque_adr_ = sensor_adr("joystick_torque");
    if (surface_joint_ >= 0) set_surface(surface);
    reset_to_keyframe("ready");
  } catch (...) {
    mj_deleteData(data_);
    mj_deleteModel(model_);
    throw;
  }
}

Pa10Plant::~Pa10Plant() {
  mj_deleteData(data_);
  mj_deleteModel(model_);
}

void Pa10Plant::set_surface(const Surface& surface) {
  if (surface_joint_ < 0) throw SceneError("the scene has a rigid table: no 'surface' joint");
  if (!(surface.stiffness_N_m > 0) || !(surface.damping_ratio >= 0))
    throw SceneError("surface '" + surface.name + "': stiffness must be > 0, damping ratio >= 0");
  const double plate_kg = model_->body_mass[model_->jnt_bodyid[surface_joint_]];
  const int dof = model_->jnt_dofadr[surface_joint_];
  const double gravity_m_s2 = -model_->opt.gravity[2];
  model_->jnt_stiffness[surface_joint_] = surface.stiffness_N_m;
  model_->dof_damping[dof] = 2 * surface.damping_ratio * std::sqrt(surface.stiffness_N_m * plate_kg);
  // The spring's rest length carries the plate's weight: at rest the top is where the scene
  // puts it (joint position 0).
  model_->qpos_spring[model_->jnt_qposadr[surface_joint_]] = plate_kg * gravity_m_s2 / surface.stiffness_N_m;
  surface_ = surface;
}

double Pa10Plant::surface_deflection_m() const {
  if (surface_joint_ < 0) return 0;
  return -data_->qpos[model_->jnt_qposadr[surface_joint_]];
}

bool Pa10Plant::tool_on_top(const mjContact_& contact) const {
  return (contact.geom1 == tool_geom_ && contact.geom2 == table_top_geom_) ||
         (contact.geom2 == tool_geom_ && contact.geom1 == table_top_geom_);
}

double Pa10Plant::tool_indentation_m() const {
  double penetration_m = 0;
  bool touching = false;
  for (int i = 0; i < data_->ncon; ++i) {
    const mjContact& contact = data_->contact[i];
    if (!tool_on_top(contact) || contact.dist > 0) continue;
    touching = true;
    penetration_m = std::max(penetration_m, -contact.dist);
  }
  return touching ? surface_deflection_m() + penetration_m : 0;
}

void Pa10Plant::reset_to_keyframe(const std::string& name) {
  const int key = mj_name2id(model_, mjOBJ_KEY, name.c_str());
  if (key < 0) throw SceneError("the scene has no keyframe '" + name + "'");
  mj_resetDataKeyframe(model_, data_, key);
  normal_force_N_ = 0;
  std::array<double, kJointCount> q{};
  std::copy_n(data_->qpos, kJointCount, q.begin());
  set_joint_positions(q);
}

void Pa10Plant::set_joint_positions(const std::array<double, kJointCount>& q_rad) {
  for (int j = 0; j < kJointCount; ++j) {
    data_->qpos[j] = q_rad[static_cast<std::size_t>(j)];
    data_->qvel[j] = 0;
    commands_[static_cast<std::size_t>(j)] = {};
    hold_position_rad_[static_cast<std::size_t>(j)] = q_rad[static_cast<std::size_t>(j)];
    velocity_error_integral_rad_[static_cast<std::size_t>(j)] = 0;
    held_load_1_s2_[static_cast<std::size_t>(j)] = 0;
  }
  mj_forward(model_, data_);
}

void Pa10Plant::set_command(int joint, const JointCommand& command) {
  const auto j = static_cast<std::size_t>(joint);
  const bool engaging_brake =
      command.mode == JointCommand::Mode::hold && commands_[j].mode != JointCommand::Mode::hold;
  const bool releasing_brake =
      command.mode == JointCommand::Mode::velocity && commands_[j].mode == JointCommand::Mode::hold;
  if (engaging_brake) {
    // The load the joint bears (what the integral pushed with, less the joint damping, which
    // stops with the joint) is held by the brake and handed back to the loop on release, so
    // a joint pushing on something neither yields nor jolts.
    for (int i = 0; i < model_->nv; ++i)
      scratch_torque_Nm_[static_cast<std::size_t>(i)] = model_->dof_damping[i] * data_->qvel[i];
    mj_solveM(model_, data_, scratch_acceleration_.data(), scratch_torque_Nm_.data(), 1);
    held_load_1_s2_[j] =
        gains_.discrete_velocity_integral_1_s2(model_->opt.timestep) * velocity_error_integral_rad_[j] - scratch_acceleration_[j];
    // An ideal brake: the joint stops where it is.
    hold_position_rad_[j] = data_->qpos[joint];
    data_->qvel[joint] = 0;
  }
  if (releasing_brake) velocity_error_integral_rad_[j] = held_load_1_s2_[j] / gains_.discrete_velocity_integral_1_s2(model_->opt.timestep);
  commands_[j] = command;
}

void Pa10Plant::set_operator_wrench(const Wrench& wrench) {
  // MuJoCo applies xfrc_applied at the body's centre of mass: move the torque there so the
  // wrench about the sensor origin is the one asked for (T_com = T_site + (site - com) x F).
  const mjtNum* com = data_->xipos + 3 * joystick_body_;
  const mjtNum* site = data_->site_xpos + 3 * joystick_site_;
  const mjtNum arm_m[3] = {site[0] - com[0], site[1] - com[1], site[2] - com[2]};
  mjtNum force[3];
  mjtNum moment[3];
  for (int i = 0; i < 3; ++i) force[i] = wrench.force_N[static_cast<std::size_t>(i)];
  mju_cross(moment, arm_m, force);
  mjtNum* applied = data_->xfrc_applied + 6 * joystick_body_;
  for (int i = 0; i < 3; ++i) {
    applied[i] = force[i];
    applied[3 + i] = wrench.torque_Nm[static_cast<std::size_t>(i)] + moment[i];
  }
}

void Pa10Plant::compute_servo_torques() {
  const double dt_s = model_->opt.timestep;
  const double kv = gains_.discrete_velocity_gain_1_s(dt_s);
  const double ki = gains_.discrete_velocity_integral_1_s2(dt_s);
  for (int j = 0; j < kJointCount; ++j) {
    const auto k = static_cast<std::size_t>(j);
    const double qdot = data_->qvel[j];
    if (commands_[k].mode == JointCommand::Mode::velocity) {
      const double error = commands_[k].target_velocity_rad_s - qdot;
      velocity_error_integral_rad_[k] += error * dt_s;
      desired_acceleration_[k] = kv * error + ki * velocity_error_integral_rad_[k];
    } else {
      desired_acceleration_[k] = gains_.hold_stiffness_1_s2 * (hold_position_rad_[k] - data_->qpos[j]) -
                                 gains_.hold_damping_1_s * qdot + held_load_1_s2_[k];
    }
  }
  // tau = M(q) a + bias(q, qdot): decoupled joints, no sag. The table top is a tree of its
  // own (M is block diagonal): its row asks for nothing and has no motor.
  if (surface_joint_ >= 0) desired_acceleration_[kJointCount] = 0;
  mj_mulM(model_, data_, torque_Nm_.data(), desired_acceleration_.data());
  for (int j = 0; j < kJointCount; ++j) {
    const double tau = torque_Nm_[static_cast<std::size_t>(j)] + data_->qfrc_bias[j];
    data_->ctrl[j] = std::clamp(tau, model_->actuator_ctrlrange[2 * j],
                                model_->actuator_ctrlrange[2 * j + 1]);
  }
}

void Pa10Plant::step() {
  // Split step: step1 brings M(q) and the bias forces up to date for this state, the servo
  // uses them, step2 applies the torques and integrates.
  mj_step1(model_, data_);
  apply_tool_friction();
  compute_servo_torques();
  mj_step2(model_, data_);
  measure_tool_normal_force();
}

void Pa10Plant::measure_tool_normal_force() {
  normal_force_N_ = 0;
  for (int i = 0; i < data_->ncon; ++i) {
    if (!tool_on_top(data_->contact[i])) continue;
    mjtNum force[6];
    mj_contactForce(model_, data_, i, force);  // contact frame: [0] along the normal
    normal_force_N_ += std::max(0.0, static_cast<double>(force[0]));
  }
}

void Pa10Plant::apply_tool_friction() {
  mjtNum* applied = data_->xfrc_applied + 6 * tool_body_;
  std::fill(applied, applied + 6, 0.0);
  if (normal_force_N_ <= 0 || surface_.friction <= 0) return;
  // The tip's linear velocity in the world frame; the top moves along z alone, so its velocity
  // along the top (x, y) is the slip.
  mjtNum velocity[6];
  mj_objectVelocity(model_, data_, mjOBJ_SITE, tool_site_, velocity, 0);
  const double vx = velocity[3], vy = velocity[4];
  const double scale = surface_.friction * normal_force_N_ / std::max(std::hypot(vx, vy), kSlipSpeed_m_s);
  const mjtNum force[3] = {-scale * vx, -scale * vy, 0};
  // MuJoCo applies xfrc_applied at the body's centre of mass: move the moment there.
  const mjtNum* tip = data_->site_xpos + 3 * tool_site_;
  const mjtNum* com = data_->xipos + 3 * tool_body_;
  const mjtNum lever[3] = {tip[0] - com[0], tip[1] - com[1], tip[2] - com[2]};
  mjtNum moment[3];
  mju_cross(moment, lever, force);
  for (int i = 0; i < 3; ++i) {
    applied[i] = force[i];
    applied[3 + i] = moment[i];
  }
}

double Pa10Plant::timestep_s() const { return model_->opt.timestep; }
double Pa10Plant::time_s() const { return data_->time; }

JointState Pa10Plant::joint_state(int joint) const {
  return {data_->qpos[joint], data_->qvel[joint]};
}

Wrench Pa10Plant::wrist_wrench() const {
  return external_wrench(data_, wrist_force_adr_, wrist_torque_adr_);
}

Wrench Pa10Plant::joystick_wrench() const {
  return external_wrench(data_, joystick_force_adr_, joystick_torque_adr_);
}

std::array<double, 3> Pa10Plant::tool_position_m() const {
  const mjtNum* p = data_->site_xpos + 3 * tool_site_;
  return {p[0], p[1], p[2]};
}

std::array<double, 9> Pa10Plant::tool_rotation() const {
  std::array<double, 9> r{};
  std::copy_n(data_->site_xmat + 9 * tool_site_, 9, r.begin());
  return r;
}

double Pa10Plant::applied_torque_Nm(int joint) const { return data_->ctrl[joint]; }

}  // namespace rtm::sim
