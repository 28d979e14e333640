// SPDX-License-Identifier: Apache-2.0
// `rtm record` against real processes: omniNames, the test talker at 2 ms, the rtm tool. The
// recording is read back with the MCAP reader and each datum decoded with the port's type.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>

#include "RTMData.hh"
#include "mcap/reader.h"
#include "rtm/cdr.h"
#include "rtm_test/orb_environment.h"
#include "rtm_test/child_process.h"
#include "rtm_test/eventually.h"
#include "rtm_test/omni_names.h"
#include "rtm_test/run_command.h"
#include "rtm_test/temp_dir.h"

namespace {

using nlohmann::json;
using rtm_test::ChildProcess;
using rtm_test::CommandResult;
using rtm_test::eventually;
using rtm_test::OmniNames;
using namespace std::chrono_literals;
namespace fs = std::filesystem;
namespace mcap = rtm::mcap;

const auto* const kOrb = ::testing::AddGlobalTestEnvironment(new rtm_test::OrbEnvironment);

class RtmRecord : public ::testing::Test {
 protected:
  std::vector<std::string> command(std::vector<std::string> args) const {
    args.insert(args.begin(), {RTM_CLI_PATH, "--naming", names_.address()});
    return args;
  }
  CommandResult rtm(std::vector<std::string> args) { return rtm_test::run_command(command(std::move(args))); }
  void talker(const std::string& name, std::vector<std::string> extra = {}) {
    std::vector<std::string> argv{TALKER_PATH, "--name", name, "--naming", names_.address()};
    argv.insert(argv.end(), extra.begin(), extra.end());
    rtm_test::start_bound(talkers_, argv);
  }
  std::string file(const std::string& name) const { return dir_.file(name); }
  // rtm record of t.force into `out`, running: it has subscribed.
  std::unique_ptr<ChildProcess> start_recorder(const std::string& out) const {
    ChildProcess::Options opts;
    opts.echo_output = false;
    auto recorder = std::make_unique<ChildProcess>(command({"record", "t.force", "-o", out}), opts);
    recorder->wait_for_line("recording t.force", 10s);
    return recorder;
  }

  // The force port's data, decoded, in log-time order.
  static std::vector<RTM::TimedFloat6> forces(const mcap::Reader& r) {
    const auto* channel = r.channel("t.force");
    EXPECT_NE(channel, nullptr);
    std::vector<RTM::TimedFloat6> out;
    if (channel == nullptr) return out;
    for (const auto& m : r.messages()) {
      if (m.channel_id != channel->id) continue;
      const CORBA::Any any = rtm::from_cdr(RTM::_tc_TimedFloat6, m.data);
      const RTM::TimedFloat6* v = nullptr;
      EXPECT_TRUE(any >>= v);
      out.push_back(*v);
      EXPECT_EQ(m.log_time, std::uint64_t{v->tm.sec} * 1'000'000'000ULL + v->tm.nsec) << "its own stamp as log time";
      EXPECT_GE(m.publish_time, m.log_time) << "received after it was stamped";
    }
    return out;
  }

  static void expect_every_datum_in_order(const std::vector<RTM::TimedFloat6>& data) {
    for (std::size_t i = 1; i < data.size(); ++i) {
      ASSERT_EQ(data[i].val[0], data[i - 1].val[0] + 1) << "datum " << i << ": the talker's ramp, none missing";
    }
  }

  OmniNames names_;
  std::vector<std::unique_ptr<ChildProcess>> talkers_;
  rtm_test::TempDir dir_{"rtm-record-test"};
};

TEST_F(RtmRecord, RecordsEveryDatumOfEachPortWithItsTypeUnitsAndTheSystem) {
  talker("t", {"--on", "--period", "2ms"});
  const auto out = file("run.mcap");
  const auto r = rtm({"--json", "record", "t.force", "t.out3", "-o", out, "--count", "300"});
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  const json result = json::parse(r.out);
  ASSERT_EQ(result["ports"].size(), 2u);
  std::uint64_t recorded = 0;
  for (const auto& p : result["ports"]) {
    recorded += p["recorded"].get<std::uint64_t>();
    EXPECT_EQ(p["dropped_by_publisher"], 0) << p;
    EXPECT_EQ(p["dropped_by_recorder"], 0) << p;
    EXPECT_EQ(p["path"], "shared memory") << "on this host the recorder reads the publisher's ring";
  }
  EXPECT_EQ(recorded, 300u);

  const mcap::Reader reader(out);
  EXPECT_EQ(reader.statistics().message_count, 300u);
  const auto* force = reader.channel("t.force");
  ASSERT_NE(force, nullptr);
  EXPECT_EQ(force->message_encoding, "cdr");
  EXPECT_EQ(force->metadata.at("type"), "RTM::TimedFloat6");
  EXPECT_EQ(force->metadata.at("elements"), "fx,fy,fz,tx,ty,tz");
  EXPECT_EQ(force->metadata.at("units"), "N,N,N,N·m,N·m,N·m");
  CORBA::TypeCode_var recorded_type = rtm::type_code_from_text(force->metadata.at("typecode"));
  EXPECT_TRUE(recorded_type->equivalent(RTM::_tc_TimedFloat6)) << "the type itself, for tools with no .idl file";
  const auto* schema = reader.schema(force->schema_id);
  ASSERT_NE(schema, nullptr);
  EXPECT_EQ(schema->encoding, "omgidl");
  EXPECT_EQ(schema->data, rtm::idl_text(RTM::_tc_TimedFloat6));
  const auto* out3 = reader.channel("t.out3");
  ASSERT_NE(out3, nullptr);
  EXPECT_EQ(reader.schema(out3->schema_id)->name, "RTM::TimedFloat3");

  const auto data = forces(reader);
  EXPECT_GT(data.size(), 100u);
  expect_every_datum_in_order(data);

  std::map<std::string, mcap::KeyValues> metadata;
  for (auto& m : reader.metadata()) metadata[m.name] = m.values;
  ASSERT_TRUE(metadata.contains("rtm.system"));
  const auto& yaml = metadata["rtm.system"].at("yaml");
  EXPECT_NE(yaml.find("name: t"), std::string::npos) << yaml;
  EXPECT_NE(yaml.find("rtm-test-talker"), std::string::npos) << "the command that started it\n" << yaml;
  ASSERT_TRUE(metadata.contains("rtm.drops"));
  EXPECT_EQ(metadata["rtm.drops"].at("t.force.recorded"), std::to_string(data.size()));
  EXPECT_EQ(metadata["rtm.drops"].at("t.force.dropped_by_publisher"), "0");
  // The system's timing, at the start and at the end: the talker's contract and how it kept it.
  ASSERT_TRUE(metadata.contains("rtm.timing"));
  ASSERT_TRUE(metadata.contains("rtm.timing.end"));
  const json before = json::parse(metadata["rtm.timing"].at("t"));
  const json after = json::parse(metadata["rtm.timing.end"].at("t"));
  EXPECT_EQ(after["period_ns"], 2'000'000);
  EXPECT_EQ(after["deadline_ns"], 2'000'000) << "the period, as no deadline was given";
  EXPECT_TRUE(after["watched"].get<bool>());
  EXPECT_GT(after["cycles"].get<std::uint64_t>(), before["cycles"].get<std::uint64_t>() + 100)
      << "the talker cycled while 300 data were recorded";

  // The format's reference reader decodes every datum with the schema the recorder wrote.
  const auto reference = rtm_test::run_command({"node", MCAP_READER, out});
  ASSERT_EQ(reference.exit_code, 0) << reference.err;
  const json decoded = json::parse(reference.out);
  EXPECT_EQ(decoded["statistics"]["messageCount"], "300");
  std::vector<double> ramp;
  for (const auto& m : decoded["messages"]) {
    if (m["topic"] == "t.force") ramp.push_back(m["data"]["val"][0].get<double>());
  }
  ASSERT_EQ(ramp.size(), data.size());
  for (std::size_t i = 0; i < ramp.size(); ++i) EXPECT_EQ(ramp[i], data[i].val[0]) << "datum " << i;
}

TEST_F(RtmRecord, CtrlCEndsWithAWholeFileAndNoSubscriptionLeft) {
  talker("t", {"--on", "--period", "2ms"});
  const auto out = file("run.mcap");
  auto recorder_process = start_recorder(out);
  auto& recorder = *recorder_process;
  // Data flow into the file: its first chunk goes out within a second.
  eventually([&] { return fs::exists(out) && fs::file_size(out) > 2000; }, 10s);
  recorder.send_signal(SIGINT);
  const auto status = recorder.wait_for_exit(10s);
  ASSERT_TRUE(status.has_value());
  EXPECT_TRUE(status->clean()) << status->to_string() << "\n" << recorder.output();

  const mcap::Reader reader(out);  // a summary: the file was closed
  const auto data = forces(reader);
  EXPECT_GT(data.size(), 10u);
  expect_every_datum_in_order(data);
  const auto cat = rtm({"--json", "cat", "t"});
  ASSERT_EQ(cat.exit_code, 0) << cat.err;
  const json described = json::parse(cat.out);
  for (const auto& p : described["ports"]) {
    if (p["name"] == "force") {
      EXPECT_TRUE(p["subscriptions"].empty()) << p;
    }
  }
}

TEST_F(RtmRecord, AKilledRecordersFileIsRecoveredUpToItsLastWholeChunk) {
  talker("t", {"--on", "--period", "2ms"});
  const auto out = file("killed.mcap");
  auto recorder_process = start_recorder(out);
  auto& recorder = *recorder_process;
  // Two chunks flushed (one a second): then killed, with no chance to write its summary.
  eventually([&] {
    std::uint64_t n = 0;
    const auto found = mcap::recover(out, [&](const mcap::Message&) { ++n; });
    return found.chunk_count >= 2;
  }, 15s);
  recorder.send_signal(SIGKILL);
  ASSERT_TRUE(recorder.wait_for_exit(10s).has_value());

  try {
    mcap::Reader unreadable(out);
    FAIL() << "a killed recorder's file read as whole";
  } catch (const mcap::FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("--recover"), std::string::npos) << e.what();
  }
  const auto fixed = file("fixed.mcap");
  const auto r = rtm({"record", "--recover", out, "-o", fixed});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("messages in"), std::string::npos) << r.out;
  const mcap::Reader reader(fixed);
  const auto data = forces(reader);
  EXPECT_GT(data.size(), 100u) << "two chunks of a 2 ms port: a second or more";
  expect_every_datum_in_order(data);
}

TEST_F(RtmRecord, APortWhoseWriterDiesLeavesWhatCameBeforeInAWholeFile) {
  talker("t", {"--on", "--period", "2ms"});
  const auto out = file("run.mcap");
  auto recorder_process = start_recorder(out);
  auto& recorder = *recorder_process;
  eventually([&] { return fs::exists(out) && fs::file_size(out) > 2000; }, 10s);
  talkers_.front()->send_signal(SIGKILL);
  ASSERT_TRUE(talkers_.front()->wait_for_exit(10s).has_value());
  EXPECT_TRUE(recorder.running()) << "the recorder outlives the port it records";
  recorder.send_signal(SIGTERM);
  ASSERT_TRUE(recorder.wait_for_exit(15s).has_value());
  const mcap::Reader reader(out);
  const auto data = forces(reader);
  EXPECT_GT(data.size(), 10u);
  expect_every_datum_in_order(data);
}

// The InPort counter of component `name`'s port `port`.
std::uint64_t accepted(const json& cat, const std::string& port) {
  for (const auto& p : cat["ports"])
    if (p["name"] == port) return p["counters"]["accepted"].get<std::uint64_t>();
  return 0;
}

TEST_F(RtmRecord, PlayPutsARecordingIntoTheInPortItsPortFedNoFasterThanRecorded) {
  talker("t", {"--on", "--period", "2ms"});
  talker("u");
  ASSERT_EQ(rtm({"connect", "t.force", "u.in0"}).exit_code, 0);
  const auto out = file("run.mcap");
  auto r = rtm({"record", "t.force", "-o", out, "--count", "200"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // From now on only the player feeds u.in0.
  ASSERT_EQ(rtm({"disconnect", "t.force", "u.in0"}).exit_code, 0);
  ASSERT_EQ(rtm({"off", "t"}).exit_code, 0);
  const auto before = rtm({"--json", "cat", "u"});
  ASSERT_EQ(before.exit_code, 0) << before.err;

  r = rtm({"--json", "play", out});
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  const json played = json::parse(r.out);
  ASSERT_EQ(played["routes"].size(), 1u) << played;
  EXPECT_EQ(played["routes"][0]["topic"], "t.force");
  EXPECT_EQ(played["routes"][0]["port"], "u.in0") << "where t.force went when it was recorded";
  EXPECT_EQ(played["routes"][0]["put"], 200);
  EXPECT_EQ(played["routes"][0]["failed"], 0);
  const mcap::Reader reader(out);
  const double span_s = static_cast<double>(reader.statistics().message_end_time - reader.statistics().message_start_time) / 1e9;
  EXPECT_GE(played["seconds"].get<double>(), span_s) << "each datum at its recorded offset, none early";
  const auto after = rtm({"--json", "cat", "u"});
  EXPECT_EQ(accepted(json::parse(after.out), "in0") - accepted(json::parse(before.out), "in0"), 200u);

  // Four times as fast, from a chosen second onwards, to a port named by --map.
  r = rtm({"--json", "play", out, "--rate", "4", "--map", "t.force=u.in0", "--from", "0.2"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json faster = json::parse(r.out);
  EXPECT_LT(faster["routes"][0]["put"].get<int>(), 200);
  EXPECT_GT(faster["routes"][0]["put"].get<int>(), 50);
  EXPECT_GE(faster["seconds"].get<double>(), (span_s - 0.2) / 4);
}

TEST_F(RtmRecord, AllRecordsEveryOutPortOfEveryComponent) {
  talker("t", {"--on", "--period", "2ms"});
  talker("u", {"--on", "--period", "2ms"});
  const auto out = file("all.mcap");
  const auto r = rtm({"--json", "record", "--all", "-o", out, "--count", "400"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const mcap::Reader reader(out);
  std::vector<std::string> topics;
  for (const auto& c : reader.channels()) topics.push_back(c.topic);
  std::sort(topics.begin(), topics.end());
  EXPECT_EQ(topics, (std::vector<std::string>{"t.force", "t.out3", "u.force", "u.out3"}));
  EXPECT_EQ(reader.statistics().message_count, 400u);
  EXPECT_GT(reader.statistics().channel_message_counts.at(reader.channel("u.force")->id), 50u);
}

TEST_F(RtmRecord, PlayLoopsUntilStoppedAndSaysHowManyPasses) {
  talker("t", {"--on", "--period", "2ms"});
  talker("u");
  const auto out = file("run.mcap");
  ASSERT_EQ(rtm({"record", "t.force", "-o", out, "--count", "50"}).exit_code, 0);
  ChildProcess::Options opts;
  opts.echo_output = false;
  ChildProcess player(command({"--json", "play", out, "--map", "t.force=u.in0", "--loop"}), opts);
  // Three passes' worth reached u.in0: the recording is played again and again.
  eventually([&] { return accepted(json::parse(rtm({"--json", "cat", "u"}).out), "in0") >= 150; }, 15s);
  player.send_signal(SIGINT);
  const auto status = player.wait_for_exit(10s);
  ASSERT_TRUE(status.has_value());
  EXPECT_TRUE(status->clean()) << status->to_string() << player.output();
  const auto output = player.output();
  const json played = json::parse(output.substr(output.find('{')));
  EXPECT_GE(played["loops"].get<int>(), 3) << played;
  EXPECT_GE(played["routes"][0]["put"].get<int>(), 150) << played;
}

TEST_F(RtmRecord, PlayingIntoAPortOfAnotherTypeIsRefusedBeforeAnythingIsPut) {
  talker("t", {"--on", "--period", "2ms"});
  const auto out = file("run.mcap");
  ASSERT_EQ(rtm({"record", "t.force", "-o", out, "--count", "20"}).exit_code, 0);
  const auto r = rtm({"play", out, "--map", "t.force=t.pos3"});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("t.force (RTM::TimedFloat6, cdr) -> t.pos3 (RTM::TimedFloat3): types differ"), std::string::npos)
      << r.err;
  EXPECT_EQ(accepted(json::parse(rtm({"--json", "cat", "t"}).out), "pos3"), 0u);
  const auto none = rtm({"play", out});
  EXPECT_NE(none.exit_code, 0);
  EXPECT_NE(none.err.find("--map"), std::string::npos) << "nothing was wired to t.force: say how to send it\n" << none.err;
}

TEST_F(RtmRecord, AnInPortAMissingPortAndAnExistingFileAreRefusedBeforeAnythingIsWritten) {
  talker("t");
  const auto out = file("run.mcap");
  auto r = rtm({"record", "t.in0", "-o", out});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("t.in0 is an InPort"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
  r = rtm({"record", "t.nothing", "-o", out});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("nothing"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
  { std::ofstream(out) << "keep me"; }
  r = rtm({"record", "t.force", "-o", out, "--count", "1"});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("exists"), std::string::npos) << r.err;
  std::ifstream in(out);
  std::string kept;
  std::getline(in, kept);
  EXPECT_EQ(kept, "keep me");

  // A symbolic link planted where the recording goes (another user's trap in a shared folder)
  // is not written through, even with --force.
  const auto planted = file("planted.mcap");
  fs::create_symlink(out, planted);
  r = rtm({"record", "t.force", "-o", planted, "--count", "1", "--force"});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("symbolic link"), std::string::npos) << r.err;
  std::ifstream again(out);
  std::getline(again, kept);
  EXPECT_EQ(kept, "keep me");
}

TEST_F(RtmRecord, ARecordingIsItsOwnersAlone) {
  talker("t", {"--on", "--period", "2ms"});
  const auto out = file("private.mcap");
  ASSERT_EQ(rtm({"record", "t.force", "-o", out, "--count", "5"}).exit_code, 0);
  EXPECT_EQ(fs::status(out).permissions() & fs::perms::all, fs::perms::owner_read | fs::perms::owner_write)
      << "the data the access screen keeps to its owner stay its owner's on disk";
  fs::permissions(out, fs::perms::all);  // a file it replaces (--force) takes the same mode
  ASSERT_EQ(rtm({"record", "t.force", "-o", out, "--count", "5", "--force"}).exit_code, 0);
  EXPECT_EQ(fs::status(out).permissions() & fs::perms::all, fs::perms::owner_read | fs::perms::owner_write);
}

}  // namespace
