// SPDX-License-Identifier: Apache-2.0
// What the emulated CAN nodes stand in front of: the PA10's seven joint servos and the two
// force sensors' mechanical side.
//
// Pa10Rig drives a Plant: it hands each drive's JointCommand to its joint, steps the plant by
// timestep_s() and reads back the joint states and the sensors' wrenches for the TPDOs. Two
// plants implement it: Pa10Plant (the MuJoCo scene, pa10-sim) and KinematicPlant (joint
// velocity integrated to position, settable wrenches; the CAN master's tests), so the same
// devices answer the master on either.
#pragma once

#include "sim/drive_device.h"
#include "sim/wrench.h"

namespace rtm::sim {

inline constexpr int kJointCount = 7;

class Plant {
 public:
  virtual ~Plant() = default;

  // What joint i's servo does from the next step on.
  virtual void set_command(int joint, const JointCommand& command) = 0;
  // The operator's wrench on the joystick handle, at the joystick sensor's origin.
  virtual void set_operator_wrench(const Wrench& wrench) = 0;
  // One step of timestep_s(). Allocates nothing.
  virtual void step() = 0;

  virtual double timestep_s() const = 0;
  virtual JointState joint_state(int joint) const = 0;
  // The wrenches the two sensors measure, untared, each in its sensor's frame.
  virtual Wrench wrist_wrench() const = 0;
  virtual Wrench joystick_wrench() const = 0;
};

}  // namespace rtm::sim
