// Time per call of the PA10 kinematics on the 2 ms control path: the velocity IK in its three
// regimes (free, near a singularity, a joint held at its limit), and FK / Jacobian alone.
// Target: a velocity IK solve well under 20 us, so it fits a 2 ms cycle with room to spare.
#include "arm/pa10/kinematics.h"

#include <benchmark/benchmark.h>

#include <numbers>

namespace {

using rtm::pa10::JointVector;
using rtm::pa10::Kinematics;
using rtm::pa10::Twist;
using rtm::pa10::VelocityIk;

JointVector generalPose() {
  JointVector q;
  q << 0.3, 0.5, -0.4, 1.3, 0.6, 0.9, -0.5;
  return q;
}

Twist forceServoTwist() {
  Twist twist;
  twist << 0.05, 0.02, -0.03, 0.1, 0.0, 0.2;  // m/s, rad/s
  return twist;
}

void solveAt(benchmark::State& state, const JointVector& q, const Twist& twist) {
  Kinematics kinematics = Kinematics::pa10();
  VelocityIk ik(kinematics);
  for (auto _ : state) {
    auto result = ik.solve(twist, q, 0.002);
    benchmark::DoNotOptimize(result);
  }
}

void BM_VelocityIk_General(benchmark::State& state) {
  solveAt(state, generalPose(), forceServoTwist());
}
BENCHMARK(BM_VelocityIk_General);

void BM_VelocityIk_NearSingular(benchmark::State& state) {
  JointVector q;
  q << 0.2, 0.6, 0.1, 1.4, std::numbers::pi / 2, 1e-4, 0.4;  // wrist singularity
  solveAt(state, q, forceServoTwist());
}
BENCHMARK(BM_VelocityIk_NearSingular);

void BM_VelocityIk_VelocityScaled(benchmark::State& state) {
  solveAt(state, generalPose(), forceServoTwist() * 30);
}
BENCHMARK(BM_VelocityIk_VelocityScaled);

void BM_VelocityIk_JointHeldAtLimit(benchmark::State& state) {
  Kinematics kinematics = Kinematics::pa10();
  JointVector q = generalPose();
  q[2] = kinematics.limits().upper_rad[2];  // s3 on its limit, commanded further into it
  solveAt(state, q, kinematics.jacobian(q).col(2) * 0.2);
}
BENCHMARK(BM_VelocityIk_JointHeldAtLimit);

void BM_ToolPose(benchmark::State& state) {
  Kinematics kinematics = Kinematics::pa10();
  const JointVector q = generalPose();
  for (auto _ : state) benchmark::DoNotOptimize(kinematics.tool_pose(q));
}
BENCHMARK(BM_ToolPose);

void BM_Jacobian(benchmark::State& state) {
  Kinematics kinematics = Kinematics::pa10();
  const JointVector q = generalPose();
  for (auto _ : state) benchmark::DoNotOptimize(kinematics.jacobian(q));
}
BENCHMARK(BM_Jacobian);

}  // namespace

BENCHMARK_MAIN();
