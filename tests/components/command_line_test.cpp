// SPDX-License-Identifier: Apache-2.0
// The component executables' command lines: the controller's and the actuator's parameters are
// registered once, by their parameter structs, so rtm-servo offers the same options with the
// same checks; a bad value is refused with exit status 2 naming it, before anything starts. The
// force sensor is one component for both nodes: rtm-joystick is rtm-sensor on the joystick's.
#include <gtest/gtest.h>

#include <chrono>
#include <string>
#include <vector>

#include "rtm_test/child_process.h"

namespace {

using namespace std::chrono_literals;

struct Outcome {
  int code = -1;
  std::string output;
};

Outcome run(std::vector<std::string> argv) {
  rtm_test::ChildProcess::Options quiet;
  quiet.echo_output = false;
  rtm_test::ChildProcess process(std::move(argv), quiet);
  const auto status = process.wait_for_exit(20s);
  if (!status) return {};
  return {status->exited ? status->code : -1, process.output()};
}

// An option's --help entry: its line, and the description on the next line when CLI11 wrapped
// it there, with runs of spaces made one (an option group indents its entries further).
std::string help_entry(const std::string& help, const std::string& option) {
  const auto at = help.find("  " + option + " ");
  if (at == std::string::npos) return "";
  auto end = help.find('\n', at);
  const auto next_end = help.find('\n', end + 1);
  const std::string next = help.substr(end + 1, next_end - end - 1);
  const auto first = next.find_first_not_of(' ');
  if (first != std::string::npos && first > 20 && next[first] != '-') end = next_end;  // wrapped description
  std::string entry;
  for (char c : help.substr(at, end - at)) {
    if (c == '\n') c = ' ';
    if (c == ' ' && (entry.empty() || entry.back() == ' ')) continue;
    entry += c;
  }
  return entry;
}

TEST(ComponentCommandLine, ANonFiniteGainIsRefusedWithExitStatusTwoNamingIt) {
  const auto r = run({RTM_CONTROLLER_EXE, "--gain", "0.003", "0.003", "nan", "0", "0", "0"});
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("gain[2] = nan is not a finite number"), std::string::npos) << r.output;
}

TEST(ComponentCommandLine, AZeroWatchdogIsRefusedBeforeTheActuatorOpensItsBus) {
  const auto r = run({RTM_ACTUATOR_EXE, "--watchdog-periods", "0", "--bus", "local:/nonexistent/dir/bus"});
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("--watchdog-periods: Value 0 not in range 1 to 1000"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("/nonexistent/dir/bus"), std::string::npos) << "the bus was opened:\n" << r.output;
}

TEST(ComponentCommandLine, AFollowingErrorWindowOutOfRangeOrNotFiniteIsRefusedBeforeTheActuatorOpensItsBus) {
  const std::vector<std::vector<std::string>> bad{{"--following-velocity-window", "nan"},
                                                  {"--following-velocity-window", "-0.1"},
                                                  {"--following-position-window", "inf"},
                                                  {"--following-periods", "0"},
                                                  {"--following-position-periods", "4000000000"}};
  for (const auto& option : bad) {
    const auto r = run({RTM_ACTUATOR_EXE, option[0], option[1], "--bus", "local:/nonexistent/dir/bus"});
    EXPECT_EQ(r.code, 2) << option[0] << " " << option[1] << ":\n" << r.output;
    EXPECT_NE(r.output.find(option[0]), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("/nonexistent/dir/bus"), std::string::npos) << "the bus was opened:\n" << r.output;
  }
}

TEST(ComponentCommandLine, AWatchdogSoLongItIsNoneOrAPeriodOfOneNanosecondIsRefused) {
  for (const std::vector<std::string>& bad : {std::vector<std::string>{"--watchdog-periods", "4000000000"},
                                              {"--watchdog-periods", "1001"},
                                              {"--period", "1ns"}}) {
    const auto r = run({RTM_ACTUATOR_EXE, bad[0], bad[1], "--bus", "local:/nonexistent/dir/bus"});
    EXPECT_EQ(r.code, 2) << bad[0] << " " << bad[1] << ":\n" << r.output;
    EXPECT_EQ(r.output.find("/nonexistent/dir/bus"), std::string::npos) << "the bus was opened:\n" << r.output;
  }
}

TEST(ComponentCommandLine, TheWrongNumberOfGainsIsABadCommandLine) {
  const auto r = run({RTM_CONTROLLER_EXE, "--gain", "1", "2"});
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("--gain"), std::string::npos) << r.output;
}

TEST(ComponentCommandLine, TheServoChecksItsMembersParametersAsTheMembersDo) {
  const auto gain = run({RTM_SERVO_EXE, "--shared-tick", "--gain", "1", "1", "1", "inf", "0", "0"});
  EXPECT_EQ(gain.code, 2) << gain.output;
  EXPECT_NE(gain.output.find("gain[3] = inf is not a finite number"), std::string::npos) << gain.output;
  const auto limit = run({RTM_SERVO_EXE, "--shared-tick", "--limit", "1", "1", "-1", "1", "1", "1"});
  EXPECT_EQ(limit.code, 2) << limit.output;
  EXPECT_NE(limit.output.find("limit[2] = -1"), std::string::npos) << limit.output;
}

TEST(ComponentCommandLine, TheServoOffersTheMembersOptionsWithTheSameHelpAndDefaults) {
  const auto servo = run({RTM_SERVO_EXE, "--help"});
  const auto controller = run({RTM_CONTROLLER_EXE, "--help"});
  const auto actuator = run({RTM_ACTUATOR_EXE, "--help"});
  ASSERT_EQ(servo.code, 0) << servo.output;
  for (const char* option : {"--gain", "--stale-periods"}) {
    const auto entry = help_entry(controller.output, option);
    ASSERT_FALSE(entry.empty()) << option << " missing from rtm-controller --help:\n" << controller.output;
    EXPECT_EQ(help_entry(servo.output, option), entry) << option;
  }
  for (const char* option : {"--limit", "--watchdog-periods", "--bus", "--sensor-bus"}) {
    const auto entry = help_entry(actuator.output, option);
    ASSERT_FALSE(entry.empty()) << option << " missing from rtm-actuator --help:\n" << actuator.output;
    EXPECT_EQ(help_entry(servo.output, option), entry) << option;
  }
}

TEST(ComponentCommandLine, TheServoRefusesATickLeadWithoutTheMasterRunningTheBusCycle) {
  const auto r = run({RTM_SERVO_EXE, "--shared-tick", "--tick-lead-us", "50"});
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("--tick-lead-us: applies to --bus-cycle master only"), std::string::npos) << r.output;
}

// --stamp-from and --watch-chain name ports: a malformed one is a bad command line (2), a port
// or member the component lacks stops it before it binds a name (1), each saying what it has.
TEST(ComponentCommandLine, AStampDerivationOrChainNamingAPortOrMemberTheComponentLacksIsRefusedSayingWhatItHas) {
  const auto malformed = run({RTM_CONTROLLER_EXE, "--stamp-from", "twist"});
  EXPECT_EQ(malformed.code, 2) << malformed.output;
  EXPECT_NE(malformed.output.find("--stamp-from 'twist': want OUT=IN[+IN...]"), std::string::npos) << malformed.output;
  const auto no_out = run({RTM_CONTROLLER_EXE, "--stamp-from", "nosuch=wrench"});
  EXPECT_EQ(no_out.code, 1) << no_out.output;
  EXPECT_NE(no_out.output.find("controller0 has no OutPort nosuch (it has twist)"), std::string::npos) << no_out.output;
  const auto no_in = run({RTM_CONTROLLER_EXE, "--stamp-from", "twist=wrench+nosuch"});
  EXPECT_EQ(no_in.code, 1) << no_in.output;
  EXPECT_NE(no_in.output.find("controller0 has no InPort nosuch (it has wrench, reference)"), std::string::npos)
      << no_in.output;
  const auto no_member = run({RTM_CONTROLLER_EXE, "--watch-chain", "c:sensor0.wrench"});
  EXPECT_EQ(no_member.code, 1) << no_member.output;
  EXPECT_NE(no_member.output.find("--watch-chain c: controller0 has no members in this process: no member sensor0"),
            std::string::npos)
      << no_member.output;
}

TEST(ComponentCommandLine, TheSensorsNodeIsOneOfTheTwoAndTheJoystickIsTheSensorOnItsNode) {
  const auto bad = run({RTM_SENSOR_EXE, "--node", "elbow", "--bus", "local:/nonexistent/dir/bus"});
  EXPECT_EQ(bad.code, 2) << bad.output;
  EXPECT_NE(bad.output.find("--node: elbow not in {wrist,joystick}"), std::string::npos) << bad.output;
  EXPECT_EQ(bad.output.find("/nonexistent/dir/bus"), std::string::npos) << "the bus was opened:\n" << bad.output;
  const auto sensor = run({RTM_SENSOR_EXE, "--help"});
  const auto joystick = run({RTM_JOYSTICK_EXE, "--help"});
  ASSERT_EQ(sensor.code, 0) << sensor.output;
  ASSERT_EQ(joystick.code, 0) << joystick.output;
  EXPECT_NE(help_entry(sensor.output, "--node"), "");
  EXPECT_EQ(help_entry(joystick.output, "--node"), "") << "rtm-joystick reads the joystick's node only";
  EXPECT_NE(help_entry(joystick.output, "--recovery-timeout-periods"), "");
  EXPECT_EQ(help_entry(joystick.output, "--recovery-timeout-periods"),
            help_entry(sensor.output, "--recovery-timeout-periods"));
}

}  // namespace
