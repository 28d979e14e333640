// SPDX-License-Identifier: Apache-2.0
// `rtm replay` against real processes: omniNames, rtm-controller run with --log-cycles and fed by
// `rtm put`, `rtm record` of its command beside it. The controller's logic run again on the log
// writes, byte for byte, what the run wrote and the recorder recorded; another gain is reported
// with where and by how much. The format's reference reader reads the log.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <signal.h>

#include <filesystem>
#include <memory>
#include <sstream>

#include "RTMData.hh"
#include "mcap/reader.h"
#include "rtm/cdr.h"
#include "rtm_test/child_process.h"
#include "rtm_test/omni_names.h"
#include "rtm_test/orb_environment.h"
#include "rtm_test/run_command.h"
#include "rtm_test/temp_dir.h"

namespace {

using nlohmann::json;
using rtm_test::ChildProcess;
using rtm_test::CommandResult;
using rtm_test::OmniNames;
using namespace std::chrono_literals;
namespace mcap = rtm::mcap;

const auto* const kOrb = ::testing::AddGlobalTestEnvironment(new rtm_test::OrbEnvironment);

std::vector<std::vector<std::uint8_t>> payloads(const std::string& file, const std::string& topic) {
  const mcap::Reader reader(file);
  const auto* channel = reader.channel(topic);
  EXPECT_NE(channel, nullptr) << file << " has no " << topic;
  std::vector<std::vector<std::uint8_t>> out;
  if (channel == nullptr) return out;
  for (const auto& m : reader.messages())
    if (m.channel_id == channel->id) out.push_back(m.data);
  return out;
}

class RtmReplay : public ::testing::Test {
 protected:
  std::vector<std::string> rtm_command(std::vector<std::string> args) const {
    args.insert(args.begin(), {RTM_CLI_PATH, "--naming", names_.address()});
    return args;
  }
  CommandResult rtm(std::vector<std::string> args) {
    return rtm_test::run_command(rtm_command(std::move(args)), {}, 60s);
  }

  // A run of the controller, logged and recorded: wrench at 500 Hz, reference at 250 Hz, 1.5 s.
  void run_logged() {
    ChildProcess::Options quiet;
    quiet.echo_output = false;
    ChildProcess controller({RTM_CONTROLLER_PATH, "--naming", names_.address(), "--log-cycles", log_, "--on"}, quiet);
    controller.wait_until_bound(20s);
    ChildProcess recorder(rtm_command({"record", "controller0.twist", "-o", recording_}), quiet);
    recorder.wait_for_line("recording controller0.twist", 20s);
    ChildProcess reference(rtm_command({"put", "controller0.reference", "0", "0", "10", "0", "0", "0.05", "--rate",
                                        "250", "--for", "1.5"}),
                           quiet);
    const auto wrench = rtm({"put", "controller0.wrench", "0.5", "-1", "-9", "0.01", "0", "0", "--rate", "500", "--for",
                             "1.5"});
    ASSERT_EQ(wrench.exit_code, 0) << wrench.err;
    const auto fed = reference.wait_for_exit(20s);
    ASSERT_TRUE(fed.has_value() && fed->clean()) << reference.output();
    controller.send_signal(SIGINT);
    const auto stopped = controller.wait_for_exit(20s);
    ASSERT_TRUE(stopped.has_value() && stopped->clean()) << controller.output();
    recorder.send_signal(SIGINT);
    const auto recorded = recorder.wait_for_exit(20s);
    ASSERT_TRUE(recorded.has_value()) << recorder.output();
  }

  OmniNames names_;
  rtm_test::TempDir dir_{"rtm-replay-test"};
  std::string log_ = dir_.file("controller-cycles.mcap");
  std::string recording_ = dir_.file("run.mcap");
};

TEST_F(RtmReplay, TheControllerReplayedWritesWhatTheRunWroteAndAnotherGainIsShownWhereAndByHowMuch) {
  ASSERT_NO_FATAL_FAILURE(run_logged());

  // Unchanged: every command identical to the log's.
  const auto same = rtm({"--json", "replay", RTM_CONTROLLER_PATH, log_, "-o", dir_.file("replayed.mcap")});
  ASSERT_EQ(same.exit_code, 0) << same.out << same.err;
  const json r = json::parse(same.out);
  EXPECT_EQ(r["component"], "controller0");
  EXPECT_GT(r["cycles"].get<int>(), 500) << "1.5 s at 2 ms, and the time before and after";
  EXPECT_GT(r["writes"].get<int>(), 300);
  EXPECT_EQ(r["differing"], 0);
  EXPECT_EQ(r["unjudged"], 0);
  EXPECT_EQ(r["unanswered_reads"], 0);
  EXPECT_EQ(r["unused_answers"], 0);

  // What the log says the controller wrote is what the recorder received from it, and what the
  // replay wrote: the same bytes, in the same order.
  const auto logged = payloads(log_, "controller0.twist");
  EXPECT_EQ(logged.size(), r["writes"].get<std::size_t>());
  EXPECT_EQ(payloads(recording_, "controller0.twist"), logged);
  EXPECT_EQ(payloads(dir_.file("replayed.mcap"), "controller0.twist"), logged);

  // vz's gain doubled: every command with a vz differs, by as much again as it was.
  std::vector<double> gain;
  for (const auto& m : mcap::Reader(log_).metadata())
    if (m.name == "rtm.cycle_log") {
      std::istringstream words(m.values.at("parameter.gain"));
      for (double g = 0; words >> g;) gain.push_back(g);
    }
  ASSERT_EQ(gain.size(), 6u) << "the log keeps the parameters the run started with";
  gain[2] *= 2;
  const std::string doubled = fmt::format("{}", fmt::join(gain, " "));
  const auto other = rtm({"replay", RTM_CONTROLLER_PATH, log_, "--set", "gain=" + doubled});
  EXPECT_EQ(other.exit_code, 1) << other.out << other.err;
  EXPECT_NE(other.out.find(fmt::format("{0} of {0} writes differ", logged.size())), std::string::npos) << other.out;
  const RTM::TimedFloat6* first = nullptr;
  const CORBA::Any first_any = rtm::from_cdr(RTM::_tc_TimedFloat6, logged.front());
  ASSERT_TRUE(first_any >>= first);
  EXPECT_NE(other.out.find(fmt::format("vz: largest difference {:.6g}", std::abs(first->val[2]))), std::string::npos)
      << "the wrench and the reference were constant: each vz differs by the same\n"
      << other.out;
  EXPECT_EQ(other.out.find("vx: largest"), std::string::npos) << "vx's gain is unchanged\n" << other.out;

  // The same through the component's own option.
  std::vector<std::string> with_option{"--json", "replay", RTM_CONTROLLER_PATH, log_, "--", "--gain"};
  for (const double g : gain) with_option.push_back(fmt::format("{}", g));
  const auto option = rtm(with_option);
  EXPECT_EQ(option.exit_code, 1) << option.err;
  EXPECT_EQ(json::parse(option.out)["differing"].get<std::size_t>(), logged.size());

  // The format's reference reader reads the log and decodes each datum with its schema.
  const auto reference = rtm_test::run_command({"node", MCAP_READER, log_});
  ASSERT_EQ(reference.exit_code, 0) << reference.err;
  const json decoded = json::parse(reference.out);
  std::size_t twists = 0, cycles = 0;
  for (const auto& m : decoded["messages"]) {
    if (m["topic"] == "controller0.twist") {
      EXPECT_NEAR(m["data"]["val"][2].get<double>(), first->val[2], 1e-6);
      ++twists;
    }
    if (m["topic"] == "cycles") ++cycles;
  }
  EXPECT_EQ(twists, logged.size());
  EXPECT_GE(cycles, r["cycles"].get<std::size_t>());
}

TEST_F(RtmReplay, ALogIsRefusedToAnotherKindOfComponentAndAFileThatIsNoLogIsNamed) {
  ASSERT_NO_FATAL_FAILURE(run_logged());
  const auto talker = rtm({"replay", TALKER_PATH, log_});
  EXPECT_EQ(talker.exit_code, 2) << talker.err;
  EXPECT_NE(talker.err.find("the log is of a controller"), std::string::npos) << talker.err;
  const auto recording = rtm({"replay", RTM_CONTROLLER_PATH, recording_});
  EXPECT_EQ(recording.exit_code, 1);
  EXPECT_NE(recording.err.find("not a cycle log"), std::string::npos) << recording.err;
  const auto set = rtm({"replay", RTM_CONTROLLER_PATH, log_, "--set", "gain"});
  EXPECT_EQ(set.exit_code, 2);
  EXPECT_NE(set.err.find("NAME=VALUE"), std::string::npos) << set.err;
}

}  // namespace
