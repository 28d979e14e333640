// SPDX-License-Identifier: Apache-2.0
// The operator's wrench profile: YAML segments (hold, step, ramp), repeat, errors with context,
// and the stdin line format.
#include "sim/operator_profile.h"

#include <gtest/gtest.h>

#include <string>

using rtm::sim::OperatorProfile;
using rtm::sim::ProfileError;
using rtm::sim::Wrench;

namespace {

std::string error_of(const std::string& yaml) {
  try {
    OperatorProfile::from_yaml(yaml, "test.yaml");
  } catch (const ProfileError& error) {
    return error.what();
  }
  return "no error";
}

TEST(OperatorProfile, HoldStepRampGiveAPiecewiseLinearWrench) {
  const auto profile = OperatorProfile::from_yaml(R"(
segments:
  - hold: 1.0
  - step: {force_N: [0, 0, -10]}
  - hold: 1.0
  - ramp: {duration_s: 2.0, force_N: [4, 0, -10], torque_Nm: [0, 0, 1]}
)",
                                                  "test.yaml");
  EXPECT_EQ(profile.wrench_at(0.5), Wrench{});
  EXPECT_DOUBLE_EQ(profile.wrench_at(1.0).force_N[2], -10.0);
  EXPECT_DOUBLE_EQ(profile.wrench_at(1.5).force_N[2], -10.0);
  EXPECT_DOUBLE_EQ(profile.wrench_at(2.0).force_N[0], 0.0);
  EXPECT_DOUBLE_EQ(profile.wrench_at(3.0).force_N[0], 2.0);
  EXPECT_DOUBLE_EQ(profile.wrench_at(3.0).torque_Nm[2], 0.5);
  EXPECT_DOUBLE_EQ(profile.wrench_at(3.0).force_N[2], -10.0);
  EXPECT_DOUBLE_EQ(profile.wrench_at(10.0).force_N[0], 4.0) << "the last wrench is held";
  EXPECT_DOUBLE_EQ(profile.duration_s(), 4.0);
}

TEST(OperatorProfile, OmittedVectorKeepsItsCurrentValue) {
  const auto profile = OperatorProfile::from_yaml(R"(
segments:
  - step: {force_N: [1, 2, 3], torque_Nm: [0.1, 0.2, 0.3]}
  - step: {force_N: [5, 5, 5]}
)",
                                                  "test.yaml");
  const Wrench wrench = profile.wrench_at(0.0);
  EXPECT_DOUBLE_EQ(wrench.force_N[0], 5.0);
  EXPECT_DOUBLE_EQ(wrench.torque_Nm[2], 0.3);
}

TEST(OperatorProfile, RepeatLoopsOverTheTotalDuration) {
  const auto profile = OperatorProfile::from_yaml(R"(
repeat: true
segments:
  - ramp: {duration_s: 1.0, force_N: [10, 0, 0]}
  - hold: 1.0
)",
                                                  "test.yaml");
  EXPECT_DOUBLE_EQ(profile.wrench_at(0.25).force_N[0], 2.5);
  EXPECT_DOUBLE_EQ(profile.wrench_at(2.25).force_N[0], 2.5);
  EXPECT_DOUBLE_EQ(profile.wrench_at(3.5).force_N[0], 10.0);
}

TEST(OperatorProfile, MalformedProfilesNameTheSourceThePlaceAndTheProblem) {
  EXPECT_NE(error_of("segments: [").find("test.yaml: not valid YAML"), std::string::npos);
  EXPECT_NE(error_of("foo: 1").find("unknown key 'foo'"), std::string::npos);
  EXPECT_NE(error_of("segments: []").find("non-empty list"), std::string::npos);
  EXPECT_NE(error_of("segments:\n  - wobble: 1").find("segment 1: unknown segment 'wobble'"),
            std::string::npos);
  EXPECT_NE(error_of("segments:\n  - hold: 1\n  - ramp: {force_N: [1, 2, 3]}")
                .find("segment 2: a ramp needs duration_s"),
            std::string::npos);
  EXPECT_NE(error_of("segments:\n  - step: {force_N: [1, 2]}").find("list of 3 numbers"),
            std::string::npos);
  EXPECT_NE(error_of("segments:\n  - step: {force_N: [1, x, 2]}").find("expected a number"),
            std::string::npos);
  EXPECT_NE(error_of("segments:\n  - hold: -1").find("hold duration must be > 0"),
            std::string::npos);
  EXPECT_NE(error_of("segments:\n  - step: {force: [1, 2, 3]}").find("unknown key 'force'"),
            std::string::npos);
}

TEST(OperatorProfile, MissingFileIsAClearError) {
  try {
    OperatorProfile::from_file("/nonexistent/profile.yaml");
    FAIL() << "no error";
  } catch (const ProfileError& error) {
    EXPECT_NE(std::string(error.what()).find("/nonexistent/profile.yaml: cannot open"),
              std::string::npos);
  }
}

TEST(OperatorProfile, ShippedExampleProfilesParse) {
  const auto profile =
      OperatorProfile::from_file(std::string(RTM_SIM_PROFILES) + "/push_and_release.yaml");
  EXPECT_GT(profile.duration_s(), 0.0);
  EXPECT_GT(profile.knots().size(), 2u);
}

TEST(WrenchLine, ThreeOrSixNumbersSetTheWrench) {
  Wrench wrench;
  ASSERT_TRUE(rtm::sim::parse_wrench_line("1 -2.5 3", wrench));
  EXPECT_EQ(wrench, (Wrench{{1, -2.5, 3}, {0, 0, 0}}));
  ASSERT_TRUE(rtm::sim::parse_wrench_line("  0 0 -10 0.1 0.2 0.3 ", wrench));
  EXPECT_EQ(wrench, (Wrench{{0, 0, -10}, {0.1, 0.2, 0.3}}));
}

TEST(WrenchLine, BlankAndCommentLinesAreSkippedGarbageIsAnError) {
  Wrench wrench{{7, 7, 7}, {7, 7, 7}};
  EXPECT_FALSE(rtm::sim::parse_wrench_line("", wrench));
  EXPECT_FALSE(rtm::sim::parse_wrench_line("   # push harder", wrench));
  EXPECT_EQ(wrench.force_N[0], 7.0);
  EXPECT_THROW(rtm::sim::parse_wrench_line("1 2", wrench), ProfileError);
  EXPECT_THROW(rtm::sim::parse_wrench_line("1 2 x", wrench), ProfileError);
  EXPECT_THROW(rtm::sim::parse_wrench_line("1 2 3 4 5 6 7", wrench), ProfileError);
  EXPECT_THROW(rtm::sim::parse_wrench_line("1 2 nan", wrench), ProfileError);
}

}  // namespace
