// SPDX-License-Identifier: Apache-2.0
// Identification of the PA10 stand-in in lock-step simulation: what the tool meets and how the
// drives follow are measured from the plant's response, and each must be within 20 % of the
// value it was configured with (docs/pa10-model.md).
//
//  - Contact stiffness: the tool tip, pointing down, is pressed slowly into the table top;
//    the stiffness is the change of the pressing force between 5 N and 15 N over the change of
//    the tip's indentation (the surface's deflection plus MuJoCo's penetration at the contact
//    point) between the same two instants. The contact point, not the tool's frame: the tool
//    tilts a little as the drives give under the load, and its frame then rises against the
//    rounded tip.
//  - Drive velocity bandwidth: joint S1 (vertical axis: no gravity load) follows a sine
//    velocity target; the bandwidth is the frequency where the amplitude ratio of the actual to
//    the target velocity falls to -3 dB.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <optional>

#include "arm/pa10/kinematics.h"
#include "sim/pa10_plant.h"
#include "sim/surface.h"

using rtm::sim::JointCommand;
using rtm::sim::Pa10Plant;
using rtm::sim::ServoGains;
using rtm::sim::Surface;
using rtm::sim::kJointCount;

namespace {

constexpr double kCycle_s = 0.002;  // the bus's SYNC period: one IK solve per cycle

// Presses the tool straight down at `speed_m_s` (IK once per 2 ms cycle, as the arm library
// does) until the pressing force passes 15 N; returns the stiffness between 5 N and 15 N (the
// least-squares slope of force over indentation, every simulation step in between: the light
// plate rings briefly after the impact and two points would catch its phase), or nothing if
// 15 N was not reached within `limit_s`.
std::optional<double> measured_contact_stiffness(const Surface& surface, double speed_m_s,
                                                 double limit_s) {
  Pa10Plant plant(RTM_PA10_SCENE, ServoGains{}, surface);
  auto kinematics = rtm::pa10::Kinematics::pa10();
  rtm::pa10::VelocityIk ik(kinematics);
  const double weight_N = plant.wrist_wrench().force_N[2];
  const int steps_per_cycle = static_cast<int>(std::lround(kCycle_s / plant.timestep_s()));
  double n = 0, sum_x = 0, sum_y = 0, sum_xx = 0, sum_xy = 0;
  for (double t = 0; t < limit_s; t += kCycle_s) {
    rtm::pa10::JointVector q;
    for (int j = 0; j < kJointCount; ++j) q[j] = plant.joint_state(j).position_rad;
    rtm::pa10::Twist twist = rtm::pa10::Twist::Zero();
    twist[2] = -speed_m_s;
    const auto solution = ik.solve(twist, q, kCycle_s);
    for (int j = 0; j < kJointCount; ++j)
      plant.set_command(j, {JointCommand::Mode::velocity, solution.qdot_rad_s[j]});
    for (int i = 0; i < steps_per_cycle; ++i) {
      plant.step();
      // The table pushes the tool back along -z of the sensor frame (tool pointing down).
      const double force_N = -(plant.wrist_wrench().force_N[2] - weight_N);
      const double indentation_m = plant.tool_indentation_m();
      if (force_N >= 15) {
        if (n < 3) return std::nullopt;
        return (n * sum_xy - sum_x * sum_y) / (n * sum_xx - sum_x * sum_x);
      }
      if (force_N >= 5) {
        n += 1;
        sum_x += indentation_m;
        sum_y += force_N;
        sum_xx += indentation_m * indentation_m;
        sum_xy += indentation_m * force_N;
      }
    }
  }
  return std::nullopt;
}

// Amplitude ratio of S1's velocity to a sine target of `omega_rad_s`, from the in-phase and
// quadrature parts of both over whole periods after the start-up transient.
double velocity_amplitude_ratio(double bandwidth_rad_s, double omega_rad_s) {
  ServoGains gains;
  gains.velocity_bandwidth_rad_s = bandwidth_rad_s;
  Pa10Plant plant(RTM_PA10_SCENE, gains);
  constexpr double kAmplitude_rad_s = 0.05;
  const double dt = plant.timestep_s();
  const double period_s = 2 * std::numbers::pi / omega_rad_s;
  const int settle_steps = static_cast<int>(std::ceil(std::max(3 * period_s, 10 / bandwidth_rad_s) / dt));
  const int measure_steps = static_cast<int>(std::lround(6 * period_s / dt));
  double in_phase = 0, quadrature = 0;
  for (int i = 0; i < settle_steps + measure_steps; ++i) {
    const double t = i * dt;
    plant.set_command(0, {JointCommand::Mode::velocity, kAmplitude_rad_s * std::sin(omega_rad_s * t)});
    plant.step();
    if (i < settle_steps) continue;
    // The velocity after the step belongs to the end of the step, t + dt.
    const double v = plant.joint_state(0).velocity_rad_s;
    in_phase += v * std::sin(omega_rad_s * (t + dt));
    quadrature += v * std::cos(omega_rad_s * (t + dt));
  }
  const double amplitude = 2 * std::hypot(in_phase, quadrature) / measure_steps;
  return amplitude / kAmplitude_rad_s;
}

// The -3 dB frequency: a geometric sweep up to the first ratio below 1/sqrt(2), then
// interpolated (in log frequency) between the last two points.
double measured_velocity_bandwidth(double bandwidth_rad_s) {
  const double level = 1 / std::sqrt(2.0);
  double previous_omega = bandwidth_rad_s / 4;
  double previous_ratio = velocity_amplitude_ratio(bandwidth_rad_s, previous_omega);
  for (double omega = previous_omega * 1.1; omega < bandwidth_rad_s * 4; omega *= 1.1) {
    const double ratio = velocity_amplitude_ratio(bandwidth_rad_s, omega);
    if (ratio < level) {
      const double f = (previous_ratio - level) / (previous_ratio - ratio);
      return previous_omega * std::pow(omega / previous_omega, f);
    }
    previous_omega = omega;
    previous_ratio = ratio;
  }
  return 0;
}

class ContactStiffness : public ::testing::TestWithParam<Surface> {};

TEST_P(ContactStiffness, TheToolMeetsTheConfiguredStiffnessWithin20Percent) {
  const Surface& surface = GetParam();
  // Slow enough that the surface's damping adds under 2 % of the force change on the sponge;
  // long enough to reach 15 N through the default drives on every surface.
  const auto stiffness = measured_contact_stiffness(surface, 0.005, 40.0);
  ASSERT_TRUE(stiffness.has_value()) << surface.name << ": 15 N not reached";
  RecordProperty("measured_N_m", std::to_string(*stiffness));
  std::printf("%s: configured %.0f N/m, measured %.0f N/m\n", surface.name.c_str(),
              surface.stiffness_N_m, *stiffness);
  EXPECT_NEAR(*stiffness / surface.stiffness_N_m, 1.0, 0.2)
      << surface.name << ": measured " << *stiffness << " N/m, configured " << surface.stiffness_N_m;
}

INSTANTIATE_TEST_SUITE_P(EverySurface, ContactStiffness,
                         ::testing::ValuesIn(rtm::sim::surface_presets().begin(),
                                             rtm::sim::surface_presets().end()),
                         [](const auto& info) { return info.param.name; });

TEST(DriveIdentification, TheVelocityLoopsMinus3dBBandwidthIsTheConfiguredOneWithin20Percent) {
  for (const double configured : {25.0, 150.0, 400.0}) {
    const double measured = measured_velocity_bandwidth(configured);
    std::printf("velocity loop: configured %.1f rad/s, measured %.1f rad/s\n", configured, measured);
    EXPECT_NEAR(measured / configured, 1.0, 0.2)
        << "configured " << configured << " rad/s, measured " << measured << " rad/s";
  }
}

TEST(Surfaces, PresetsByNameAndCustomStiffnessesParseOutOfRangeOrGarbageIsRefused) {
  EXPECT_EQ(rtm::sim::parse_surface("wood").name, "wood");
  const Surface custom = rtm::sim::parse_surface("2.5e4");
  EXPECT_EQ(custom.name, "custom");
  EXPECT_DOUBLE_EQ(custom.stiffness_N_m, 25'000);
  EXPECT_DOUBLE_EQ(custom.damping_ratio, rtm::sim::parse_surface("rubber").damping_ratio)
      << "the damping ratio of the nearest preset below";
  for (const char* bad : {"glass", "", "1e7", "5", "nan", "inf", "30000N", "-300"})
    EXPECT_THROW(rtm::sim::parse_surface(bad), std::invalid_argument) << bad;
  try {
    rtm::sim::parse_surface("glass");
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("'glass'"), std::string::npos) << error.what();
  }
}

TEST(Surfaces, TheTableTopRestsAtItsNominalHeightUnderItsOwnWeightOnEverySurface) {
  for (const Surface& surface : rtm::sim::surface_presets()) {
    Pa10Plant plant(RTM_PA10_SCENE, ServoGains{}, surface);
    for (int i = 0; i < 2000; ++i) plant.step();
    EXPECT_NEAR(plant.surface_deflection_m(), 0.0, 1e-6) << surface.name;
  }
}

}  // namespace
