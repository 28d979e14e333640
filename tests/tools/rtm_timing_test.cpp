// SPDX-License-Identifier: Apache-2.0
// Timing contracts as a user meets them: `rtm check` and `rtm up` refuse a system file whose
// contracts cannot hold, with the numbers; a running component slowed past its budget is counted
// and shown by `rtm ls -l` and `rtm cat`, and one whose contract says brake stops. The real `rtm`,
// real component processes (rtm-test-talker, whose spin_us parameter makes its cycle slow) and a
// real omniNames on a free port.
#include "rtm_test/eventually.h"
#include "rtm_test/omni_names.h"
#include "rtm_test/run_command.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace {

using nlohmann::json;
using rtm_test::CommandResult;
using rtm_test::eventually;
using namespace std::chrono_literals;

class RtmTiming : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() / ("rtm-timing-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override {
    rtm({"down", "timed"});  // in case a test failed half-way
    std::filesystem::remove_all(dir_);
  }
  std::filesystem::path write_system(const std::string& yaml) {
    const auto file = dir_ / "timed.yaml";
    std::ofstream(file) << yaml;
    return file;
  }
  CommandResult rtm(std::vector<std::string> args) {
    args.insert(args.begin(), {RTM_CLI_PATH, "--naming", names_.address()});
    return rtm_test::run_command(args, {"RTM_BIN_PATH=" + std::string(RTM_TEST_BIN_DIR) + ":" + RTM_BIN_DIR,
                                        "XDG_RUNTIME_DIR=" + dir_.string()},
                                 std::chrono::seconds(30));
  }
  // A statistic of component (`rtm cat --json`), -1 when it has none or cannot be asked.
  double statistic(const std::string& component, const std::string& name) {
    const auto r = rtm({"--json", "cat", component});
    if (r.exit_code != 0) return -1;
    const json j = json::parse(r.out, nullptr, false);
    if (j.is_discarded() || !j["statistics"].contains(name)) return -1;
    return j["statistics"][name]["value"].get<double>();
  }
  json contract_of(const std::string& component) {
    const auto r = rtm({"--json", "cat", component});
    if (r.exit_code != 0) return json();
    const json j = json::parse(r.out, nullptr, false);
    return j.is_discarded() || !j.contains("contract") ? json() : j["contract"];
  }

  rtm_test::OmniNames names_;
  std::filesystem::path dir_;
};

// Three talkers pinned to CPU 0, each promising at most 0.8 ms of every 2 ms: 3 x 0.4 = 1.2 of
// the CPU. No schedule can hold that, whatever the priorities.
constexpr const char* kOverloaded = R"(
name: timed
components:
  - {name: a, command: rtm-test-talker, contract: {period: 2ms, budget: 0.8ms, cpu: 0, priority: 30}}
  - {name: b, command: rtm-test-talker, contract: {period: 2ms, budget: 0.8ms, cpu: 0, priority: 20}}
  - {name: c, command: rtm-test-talker, contract: {period: 2ms, budget: 0.8ms, cpu: 0, priority: 10}}
activate: [a, b, c]
)";

TEST_F(RtmTiming, ASystemWhoseBudgetsOverloadACpuIsRefusedWithTheNumbersAndNothingStarts) {
  const auto file = write_system(kOverloaded);
  const auto check = rtm({"check", file.string()});
  EXPECT_EQ(check.exit_code, 1) << check.out << check.err;
  EXPECT_NE(check.out.find("CPU 0"), std::string::npos) << check.out;
  EXPECT_NE(check.out.find("1.20"), std::string::npos) << "the CPU's total: " << check.out;
  EXPECT_NE(check.out.find("0.40"), std::string::npos) << "each component's share: " << check.out;

  const auto up = rtm({"up", file.string()});
  EXPECT_EQ(up.exit_code, 1) << up.out << up.err;
  EXPECT_NE(up.err.find("cannot keep its timing contracts"), std::string::npos) << up.err;
  EXPECT_NE(up.err.find("CPU 0"), std::string::npos) << up.err;
  EXPECT_NE(up.err.find("--force"), std::string::npos) << "says how to start it anyway: " << up.err;
  const auto ls = rtm({"--json", "ls"});
  ASSERT_EQ(ls.exit_code, 0) << ls.err;
  EXPECT_TRUE(json::parse(ls.out).empty()) << "nothing was started: " << ls.out;
}

TEST_F(RtmTiming, ForceStartsARefusedSystemAfterSayingEachRefusal) {
  const auto file = write_system(kOverloaded);
  const auto up = rtm({"up", "--force", file.string()});
  ASSERT_EQ(up.exit_code, 0) << up.out << up.err;
  EXPECT_NE(up.out.find("WARNING: starting despite"), std::string::npos) << up.out;
  EXPECT_NE(up.out.find("CPU 0"), std::string::npos) << up.out;
  // Each component runs the contract the file gave it.
  const json a = contract_of("a");
  ASSERT_TRUE(a.is_object()) << "a has no contract";
  EXPECT_EQ(a["budget_ns"], 800'000);
  EXPECT_EQ(a["cpu"], 0);
  EXPECT_EQ(a["period_ns"], 2'000'000);
  const auto down = rtm({"down", "timed"});
  EXPECT_EQ(down.exit_code, 0) << down.err;
}

// The demo's grid: writer at phase 0, reader 0.1 ms later awaiting the datum up to 0.15 ms, a
// third 0.1 ms after that. Each ends well within the gap, so each hop is the phase difference:
// 0.1 + 0.1 ms, plus the last one's response bound.
TEST_F(RtmTiming, CheckExplainsAChainHopByHopAndAcceptsAContractThatHolds) {
  const auto file = write_system(R"(
name: timed
components:
  - {name: a, command: rtm-test-talker, contract: {phase: 0, budget: 50us, priority: 30}}
  - {name: b, command: rtm-test-talker, contract: {phase: 0.1ms, await: "in0:0.15ms", budget: 50us, priority: 20}}
  - {name: c, command: rtm-test-talker, contract: {phase: 0.2ms, await: "in0:0.1ms", budget: 50us, priority: 10}}
chains:
  - {name: a_to_c, path: [a.force, b, c], deadline: 2ms}
)");
  const auto check = rtm({"check", file.string()});
  EXPECT_EQ(check.exit_code, 0) << check.out << check.err;
  EXPECT_NE(check.out.find("a_to_c"), std::string::npos) << check.out;
  EXPECT_NE(check.out.find("a -> b"), std::string::npos) << "hop by hop: " << check.out;
  EXPECT_NE(check.out.find("b -> c"), std::string::npos) << "hop by hop: " << check.out;

  const auto as_json = rtm({"--json", "check", file.string()});
  ASSERT_EQ(as_json.exit_code, 0) << as_json.err;
  const json j = json::parse(as_json.out);
  ASSERT_EQ(j["chains"].size(), 1u);
  const json& chain = j["chains"][0];
  ASSERT_EQ(chain["hops"].size(), 2u);
  EXPECT_EQ(chain["hops"][0]["latency_ns"], 100'000) << "a ends within 0.05 ms, b is released 0.1 ms after a";
  EXPECT_EQ(chain["hops"][1]["latency_ns"], 100'000);
  ASSERT_TRUE(chain["latency_ns"].is_number()) << chain.dump();
  const auto latency = chain["latency_ns"].get<std::int64_t>();
  EXPECT_GT(latency, 200'000) << "the hops and c's own response";
  EXPECT_LE(latency, 2'000'000);
  EXPECT_FALSE(j["refused"].get<bool>());
}

TEST_F(RtmTiming, AChainWhoseBoundExceedsItsDeadlineIsRefusedNamingTheChain) {
  // No common grid: each hop may cost a whole reader period.
  const auto file = write_system(R"(
name: timed
components:
  - {name: a, command: rtm-test-talker, contract: {budget: 50us, priority: 30}}
  - {name: b, command: rtm-test-talker, contract: {budget: 50us, priority: 20}}
chains:
  - {name: a_to_b, path: [a.force, b], deadline: 1ms}
)");
  const auto check = rtm({"check", file.string()});
  EXPECT_EQ(check.exit_code, 1) << check.out << check.err;
  EXPECT_NE(check.out.find("a_to_b"), std::string::npos) << check.out;
  EXPECT_NE(check.out.find("1 ms"), std::string::npos) << "the deadline it misses: " << check.out;
}

TEST_F(RtmTiming, AMalformedContractIsRefusedWithTheFilesLine) {
  const auto file = write_system(R"(
name: timed
components:
  - name: a
    command: rtm-test-talker
    contract: {budget: fast}
)");
  const auto check = rtm({"check", file.string()});
  EXPECT_EQ(check.exit_code, 2) << check.out << check.err;
  EXPECT_NE(check.err.find("timed.yaml:6:"), std::string::npos) << check.err;
  EXPECT_NE(check.err.find("budget 'fast'"), std::string::npos) << check.err;
  const auto up = rtm({"up", file.string()});
  EXPECT_NE(up.exit_code, 0);
  EXPECT_NE(up.err.find("timed.yaml:6:"), std::string::npos) << up.err;
}

// spin_us makes every cycle take at least that long, whatever the machine does: 600 us of
// spinning against a 300 us budget and a 500 us deadline misses both in every cycle after it.
TEST_F(RtmTiming, AComponentSlowedPastItsBudgetIsCountedAndShownAsMissed) {
  const auto file = write_system(R"(
name: timed
components:
  - {name: a, command: rtm-test-talker, contract: {budget: 300us, deadline: 500us}}
activate: [a]
)");
  const auto up = rtm({"up", file.string()});
  ASSERT_EQ(up.exit_code, 0) << up.out << up.err;
  const auto set = rtm({"set", "a", "spin_us", "600"});
  ASSERT_EQ(set.exit_code, 0) << set.err;
  ASSERT_TRUE(eventually([&] {
    const json c = contract_of("a");
    return c.is_object() && c["over_budget"].get<std::uint64_t>() >= 20 && c["missed_deadline"].get<std::uint64_t>() >= 20;
  }, 10s)) << contract_of("a").dump();
  const json c = contract_of("a");
  EXPECT_FALSE(c["deadline_met"].get<bool>());
  EXPECT_FALSE(c["budget_met"].get<bool>());
  EXPECT_GE(c["cycle_ns"]["max"].get<std::int64_t>(), 600'000) << "the longest cycle spun 600 us";
  EXPECT_GT(c["cycle_ns"]["max_at_ns"].get<std::int64_t>(), 0) << "and says when";

  const auto cat = rtm({"cat", "a"});
  EXPECT_NE(cat.out.find("budget 300 us EXCEEDED"), std::string::npos) << cat.out;
  EXPECT_NE(cat.out.find("deadline 500 us MISSED"), std::string::npos) << cat.out;
  const auto ls = rtm({"ls", "-l"});
  EXPECT_NE(ls.out.find("EXCEEDED"), std::string::npos) << ls.out;
  // The statistics say the same, for `rtm serve` and scripts.
  const auto cat_json = json::parse(rtm({"--json", "cat", "a"}).out);
  EXPECT_GE(cat_json["statistics"]["over_budget"]["value"].get<double>(), 20);
}

// A 100 ms period: no host stall makes a cycle miss its deadline before the spin starts.
TEST_F(RtmTiming, AContractThatSaysBrakeStopsTheComponentAtItsFirstMissAndSaysWhy) {
  const auto file = write_system(R"(
name: timed
components:
  - {name: a, command: rtm-test-talker, contract: {period: 100ms, budget: 300us, on_miss: brake}}
activate: [a]
)");
  const auto up = rtm({"up", file.string()});
  ASSERT_EQ(up.exit_code, 0) << up.out << up.err;
  ASSERT_EQ(rtm({"set", "a", "spin_us", "600"}).exit_code, 0);
  ASSERT_TRUE(eventually([&] {
    const auto r = rtm({"--json", "cat", "a"});
    return r.exit_code == 0 && json::parse(r.out)["state"] == "error";
  }, 10s));
  const json a = json::parse(rtm({"--json", "cat", "a"}).out);
  const std::string why = a["last_error"].get<std::string>();
  EXPECT_NE(why.find("over its budget of 300 us"), std::string::npos) << why;
  EXPECT_EQ(a["contract"]["over_budget"], 1) << "it stopped at the first";
}

// a stamps its samples 50 ms in the past; b and c pass the stamp of what they read on: the
// chain's end, c, must see data at least 50 ms old however fast the three processes are.
TEST_F(RtmTiming, AChainsEndMeasuresTheAgeOfTheSampleItsDataDeriveFromAcrossThreeProcesses) {
  const auto file = write_system(R"(
name: timed
components:
  - {name: a, command: [rtm-test-talker, --stamp-age-ms, "50"]}
  - {name: b, command: rtm-test-talker}
  - {name: c, command: rtm-test-talker}
connections:
  - {from: a.force, to: b.in0}
  - {from: b.force, to: c.in0}
activate: [a, b, c]
chains:
  - {name: a_to_c, path: [a.force, b.in0, c.in0], deadline: 20ms, max_age: 30ms}
)");
  const auto up = rtm({"up", file.string()});
  ASSERT_EQ(up.exit_code, 0) << up.out << up.err;
  ASSERT_TRUE(eventually([&] { return statistic("c", "chain.a_to_c.late") >= 20; }, 10s))
      << "c ends the chain; its data come 50 ms after their sample, past the 20 ms deadline";
  EXPECT_GE(statistic("c", "chain.a_to_c.latency_p50"), 50'000)
      << "us: the stamp a set, carried by b's force, which rtm up declared to derive from b.in0 (b never copies it)";
  EXPECT_GE(statistic("c", "chain.a_to_c.age_p99"), 50'000);
  EXPECT_GE(statistic("c", "chain.a_to_c.stale"), 20) << "every cycle acts on data older than 30 ms";
  EXPECT_EQ(statistic("b", "chain.a_to_c.late"), -1) << "only the chain's end watches it";
  const auto cat = rtm({"cat", "c"});
  EXPECT_NE(cat.out.find("chain.a_to_c.latency_p99"), std::string::npos) << cat.out;
}

// b, in the middle of the chain, slowed past its budget: its spin (5 ms between reading its
// input and writing, a lower bound on its cycle) makes every datum it passes on more than 5 ms
// old, so the chain's end, c, reports each one past the chain's 5 ms deadline, while b counts
// its cycles over budget.
TEST_F(RtmTiming, AComponentSlowedPastItsBudgetMakesTheChainThroughItMissItsDeadline) {
  const auto file = write_system(R"(
name: timed
components:
  - {name: a, command: rtm-test-talker}
  - {name: b, command: rtm-test-talker, contract: {budget: 1ms}}
  - {name: c, command: rtm-test-talker}
connections:
  - {from: a.force, to: b.in0}
  - {from: b.force, to: c.in0}
activate: [a, b, c]
chains:
  - {name: a_to_c, path: [a.force, b.in0, c.in0], deadline: 5ms}
)");
  const auto up = rtm({"up", file.string()});
  ASSERT_EQ(up.exit_code, 0) << up.out << up.err;
  ASSERT_EQ(rtm({"set", "b", "spin_us", "5000"}).exit_code, 0);
  ASSERT_TRUE(eventually([&] {
    return statistic("c", "chain.a_to_c.late") >= 10 && statistic("b", "over_budget") >= 10;
  }, 15s)) << "c: " << statistic("c", "chain.a_to_c.late") << " late; b: " << statistic("b", "over_budget")
           << " over budget (it ran 5 ms against its 1 ms)";
  EXPECT_GT(statistic("c", "chain.a_to_c.latency_max"), 5'000) << "us: more than b's spin";
}

}  // namespace
