// SPDX-License-Identifier: Apache-2.0
// pa10-sim as a process: bad input is one clear line and exit code 1; SIGTERM stops it cleanly.
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "arm/can/bus.h"
#include "arm/can/protocol.h"
#include "rtm_test/child_process.h"

using namespace std::chrono_literals;

namespace {

std::string temp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          ("rtm-sim-cli-" + std::to_string(::getpid()) + "-" + name))
      .string();
}

// Runs pa10-sim with `args`, expects exit code 1 and returns its output once `expected` (the
// start of the error line) has been read or the output has ended.
std::string failing_run(std::vector<std::string> args, const std::string& expected) {
  args.insert(args.begin(), PA10_SIM_EXE);
  rtm_test::ChildProcess::Options quiet;
  quiet.echo_output = false;
  rtm_test::ChildProcess sim(args, quiet);
  try {
    sim.wait_for_line(expected, 30s);
  } catch (const std::runtime_error&) {
    // The EXPECT on the output names what is missing.
  }
  const auto status = sim.wait_for_exit(30s);
  EXPECT_TRUE(status.has_value()) << "still running";
  if (status) {
    EXPECT_TRUE(status->exited) << status->to_string();
    EXPECT_EQ(status->code, 1) << sim.output();
  }
  return sim.output();
}

TEST(Pa10SimCli, MissingModelFileIsOneLineAndExit1) {
  const auto output = failing_run(
      {"--bus", "local:" + temp_path("a.bus"), "--model", "/nonexistent.xml"}, "pa10-sim: ");
  EXPECT_NE(output.find("pa10-sim: /nonexistent.xml: scene file not found"), std::string::npos) << output;
}

TEST(Pa10SimCli, MalformedProfileNamesFileAndSegmentAndExits1) {
  const std::string profile = temp_path("bad.yaml");
  std::ofstream(profile) << "segments:\n  - hold: 1\n  - ramp: {force_N: [1, 2, 3]}\n";
  const auto output =
      failing_run({"--bus", "local:" + temp_path("b.bus"), "--profile", profile}, "pa10-sim: ");
  EXPECT_NE(output.find(profile + ": segment 2: a ramp needs duration_s"), std::string::npos) << output;
  std::filesystem::remove(profile);
}

TEST(Pa10SimCli, UnknownBusSchemeIsOneLineAndExit1) {
  const auto output = failing_run({"--bus", "carrier-pigeon:coop"}, "pa10-sim: ");
  EXPECT_NE(output.find("pa10-sim: CAN bus 'carrier-pigeon:coop'"), std::string::npos) << output;
}

TEST(Pa10SimCli, ABadCommandLineIsExitStatusTwoNotCli11sOwnCode) {
  for (const std::vector<std::string>& bad :
       {std::vector<std::string>{"--duration", "nan", "--bus", "local:" + temp_path("d.bus")}, {"--no-such-option"}, {}}) {
    std::vector<std::string> argv{PA10_SIM_EXE};
    argv.insert(argv.end(), bad.begin(), bad.end());
    rtm_test::ChildProcess::Options quiet;
    quiet.echo_output = false;
    rtm_test::ChildProcess sim(argv, quiet);
    const auto status = sim.wait_for_exit(30s);
    ASSERT_TRUE(status.has_value()) << "still running";
    EXPECT_TRUE(status->exited && status->code == 2) << status->to_string() << "\n" << sim.output();
  }
}

TEST(Pa10SimCli, AnUnknownOrAbsurdSurfaceIsNamedAndExitStatusTwo) {
  for (const std::string bad : {"glass", "1e9", "nan"}) {
    rtm_test::ChildProcess::Options quiet;
    quiet.echo_output = false;
    rtm_test::ChildProcess sim({PA10_SIM_EXE, "--bus", "local:" + temp_path("s.bus"), "--surface", bad}, quiet);
    const auto status = sim.wait_for_exit(30s);
    ASSERT_TRUE(status.has_value()) << "still running";
    EXPECT_TRUE(status->exited && status->code == 2) << status->to_string() << "\n" << sim.output();
    EXPECT_NE(sim.output().find("surface '" + bad + "'"), std::string::npos) << sim.output();
  }
}

TEST(Pa10SimCli, SigtermStopsItCleanlyAndRemovesTheHubSocket) {
  const std::string bus = temp_path("c.bus");
  rtm_test::ChildProcess sim({PA10_SIM_EXE, "--bus", "local:" + bus});
  sim.wait_for_line("pa10-sim: ready", 20s);
  EXPECT_TRUE(std::filesystem::exists(bus)) << "pa10-sim hosts the hub when none listens";
  sim.send_signal(SIGTERM);
  EXPECT_NO_THROW(sim.wait_for_line("pa10-sim: stopped at sim time", 10s));
  const auto status = sim.wait_for_exit(10s);
  ASSERT_TRUE(status.has_value());
  EXPECT_TRUE(status->clean()) << status->to_string();
  EXPECT_FALSE(std::filesystem::exists(bus));
}

// --log: one CSV row per SYNC the drives saw, written by a thread of its own; after SIGTERM
// the file holds the header and whole rows with as many fields as it names.
TEST(Pa10SimCli, TheLogHoldsAHeaderAndOneWholeRowPerSyncSeen) {
  const std::string bus = temp_path("d.bus");
  const std::string log = temp_path("d.csv");
  rtm_test::ChildProcess sim({PA10_SIM_EXE, "--bus", "local:" + bus, "--log", log});
  sim.wait_for_line("pa10-sim: ready", 20s);
  auto master = rtm::can::open_bus("local:" + bus);
  for (int i = 0; i < 50; ++i) {
    ASSERT_TRUE(master->send(*rtm::can::encode_sync(static_cast<std::uint8_t>(i % 240 + 1))));
    std::this_thread::sleep_for(2ms);
  }
  sim.send_signal(SIGTERM);
  const auto status = sim.wait_for_exit(10s);
  ASSERT_TRUE(status.has_value());
  EXPECT_TRUE(status->clean()) << status->to_string() << sim.output();
  std::ifstream in(log);
  std::string header;
  ASSERT_TRUE(std::getline(in, header));
  EXPECT_EQ(header.rfind("time_s,q_s1_rad", 0), 0u) << header;
  const auto fields = [](const std::string& line) { return std::count(line.begin(), line.end(), ',') + 1; };
  int rows = 0;
  double last_time = -1;
  for (std::string row; std::getline(in, row); ++rows) {
    EXPECT_EQ(fields(row), fields(header)) << "row " << rows << ": " << row;
    const double t = std::stod(row);
    EXPECT_GE(t, last_time) << "row " << rows;  // two SYNCs can fall in one 1 ms step
    last_time = t;
  }
  EXPECT_GE(rows, 1) << "no row for 50 SYNCs";
  EXPECT_LE(rows, 50);
  EXPECT_EQ(sim.output().find("rows dropped"), std::string::npos) << sim.output();
  std::filesystem::remove(log);
}

}  // namespace
