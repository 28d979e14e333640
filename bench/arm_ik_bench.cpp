// SPDX-License-Identifier: Apache-2.0
// Time per call of the PA10 kinematics on the 2 ms control path: the velocity IK in its three
// regimes (free, near a singularity, a joint held at its limit), and FK / Jacobian alone, and FK
// with the rotation-vector conversion the actuator's pose port takes.
// Target: a velocity IK solve well under 20 us, so it fits a 2 ms cycle with room to spare.
#include "arm/pa10/kinematics.h"

#include <benchmark/benchmark.h>

#include <numbers>

namespace {

using rtm::pa10::JointVector;
using rtm::pa10::Kinematics;
using rtm::pa10::Twist;
using rtm::pa10::VelocityIk;

JointVector general_pose() {
  JointVector q;
  q << 0.3, 0.5, -0.4, 1.3, 0.6, 0.9, -0.5;
  return q;
}

Twist force_servo_twist() {
  Twist twist;
  twist << 0.05, 0.02, -0.03, 0.1, 0.0, 0.2;  // m/s, rad/s
  return twist;
}

void solve_at(benchmark::State& state, const JointVector& q, const Twist& twist) {
  Kinematics kinematics = Kinematics::pa10();
  VelocityIk ik(kinematics);
  for (auto _ : state) {
    auto result = ik.solve(twist, q, 0.002);
    benchmark::DoNotOptimize(result);
  }
}

void BM_VelocityIk_General(benchmark::State& state) {
  solve_at(state, general_pose(), force_servo_twist());
}
BENCHMARK(BM_VelocityIk_General);

void BM_VelocityIk_NearSingular(benchmark::State& state) {
  JointVector q;
  q << 0.2, 0.6, 0.1, 1.4, std::numbers::pi / 2, 1e-4, 0.4;  // wrist singularity
  solve_at(state, q, force_servo_twist());
}
BENCHMARK(BM_VelocityIk_NearSingular);

void BM_VelocityIk_VelocityScaled(benchmark::State& state) {
  solve_at(state, general_pose(), force_servo_twist() * 30);
}
BENCHMARK(BM_VelocityIk_VelocityScaled);

void BM_VelocityIk_JointHeldAtLimit(benchmark::State& state) {
  Kinematics kinematics = Kinematics::pa10();
  JointVector q = general_pose();
  q[2] = kinematics.limits().upper_rad[2];  // s3 on its limit, commanded further into it
  solve_at(state, q, kinematics.jacobian(q).col(2) * 0.2);
}
BENCHMARK(BM_VelocityIk_JointHeldAtLimit);

void BM_ToolPose(benchmark::State& state) {
  Kinematics kinematics = Kinematics::pa10();
  const JointVector q = general_pose();
  for (auto _ : state) benchmark::DoNotOptimize(kinematics.tool_pose(q));
}
BENCHMARK(BM_ToolPose);

// What the actuator adds to its cycle for its "pose" port (ArmHardware::measured_tool_pose, less
// the read of the master's joint state): FK, then the rotation as a rotation vector.
void BM_ToolPoseVector(benchmark::State& state) {
  Kinematics kinematics = Kinematics::pa10();
  const JointVector q = general_pose();
  for (auto _ : state) benchmark::DoNotOptimize(rtm::pa10::pose_vector(kinematics.tool_pose(q)));
}
BENCHMARK(BM_ToolPoseVector);

void BM_Jacobian(benchmark::State& state) {
  Kinematics kinematics = Kinematics::pa10();
  const JointVector q = general_pose();
  for (auto _ : state) benchmark::DoNotOptimize(kinematics.jacobian(q));
}
BENCHMARK(BM_Jacobian);

}  // namespace

BENCHMARK_MAIN();
