// SPDX-License-Identifier: Apache-2.0
// rtm-container: several components in one process, loaded from their modules, against a real
// omniNames on a free port and driven with the real `rtm` tool: each member bound, described
// and switched on its own, their connection in-process, per-member options, a clean stop; and
// what it refuses (a bad member, a module that is none or that another user could have written).
#include "rtm_test/child_process.h"
#include "rtm_test/eventually.h"
#include "rtm_test/omni_names.h"
#include "rtm_test/run_command.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <signal.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using rtm_test::ChildProcess;
using rtm_test::eventually;
using namespace std::chrono_literals;

struct Outcome {
  int code = -1;
  std::string output;
};

class RtmContainer : public ::testing::Test {
 protected:
  rtm_test::CommandResult rtm(std::vector<std::string> args) {
    args.insert(args.begin(), {RTM_CLI_PATH, "--naming", names_.address()});
    return rtm_test::run_command(args);
  }
  json cat(const std::string& name) {
    const auto r = rtm({"--json", "cat", name});
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return json::parse(r.out, nullptr, false);
  }
  std::vector<std::string> container_argv(const std::vector<std::vector<std::string>>& members) {
    std::vector<std::string> argv{RTM_CONTAINER_PATH, "--name", "cell0", "--naming", names_.address()};
    for (const auto& member : members) {
      argv.push_back("--");
      argv.insert(argv.end(), member.begin(), member.end());
    }
    return argv;
  }
  Outcome run(const std::vector<std::vector<std::string>>& members) {
    ChildProcess::Options quiet;
    quiet.echo_output = false;
    ChildProcess process(container_argv(members), quiet);
    const auto status = process.wait_for_exit(20s);
    if (!status) return {};
    return {status->exited ? status->code : -1, process.output()};
  }
  bool listed(const std::vector<std::string>& names) {
    const auto r = rtm({"--json", "ls"});
    if (r.exit_code != 0) return false;
    const json list = json::parse(r.out, nullptr, false);
    if (list.is_discarded()) return false;
    std::size_t found = 0;
    for (const auto& c : list)
      for (const auto& n : names) found += c.value("name", "") == n && c.value("alive", true);
    return found == names.size();
  }
  static const json* port(const json& component, const std::string& name) {
    for (const auto& p : component["ports"])
      if (p["name"] == name) return &p;
    return nullptr;
  }

  rtm_test::OmniNames names_;
};

TEST_F(RtmContainer, TwoMembersAreEachNamedAndSwitchedOnTheirOwnAndTheirConnectionIsInProcess) {
  ChildProcess::Options quiet;
  quiet.echo_output = false;
  ChildProcess container(container_argv({{"a", TALKER_MODULE}, {"b", TALKER_MODULE, "--period", "5ms"}}), quiet);
  container.wait_for_line("2 members up: a, b");
  ASSERT_TRUE(eventually([&] { return listed({"a", "b"}); })) << container.output();

  // One process: both report the container's pid.
  const json a = cat("a"), b = cat("b");
  ASSERT_TRUE(a.contains("statistics") && b.contains("statistics")) << a.dump() << b.dump();
  const double pid = static_cast<double>(container.pid());
  EXPECT_EQ(a["statistics"]["pid"]["value"].get<double>(), pid) << a.dump();
  EXPECT_EQ(b["statistics"]["pid"]["value"].get<double>(), pid) << b.dump();
  EXPECT_EQ(a["period_ns"], 2'000'000);
  EXPECT_EQ(b["period_ns"], 5'000'000) << "each member has its own options";

  // Their connection takes the in-process path: no CORBA call per datum.
  const auto connected = rtm({"connect", "a.force", "b.in0"});
  ASSERT_EQ(connected.exit_code, 0) << connected.err;
  const json a_connected = cat("a");
  const json* force = port(a_connected, "force");
  ASSERT_NE(force, nullptr);
  ASSERT_EQ((*force)["subscriptions"].size(), 1u) << force->dump();
  EXPECT_TRUE((*force)["subscriptions"][0]["in_process"].get<bool>()) << force->dump();

  // Switched on their own; data flows from a to b.
  ASSERT_EQ(rtm({"on", "a"}).exit_code, 0);
  ASSERT_TRUE(eventually([&] {
    const json now = cat("b");
    const json* in0 = port(now, "in0");
    return in0 != nullptr && (*in0)["counters"]["accepted"].get<unsigned long long>() > 10;
  })) << cat("b").dump();
  EXPECT_EQ(cat("b")["state"], "off") << "turning a on left b off";
  ASSERT_EQ(rtm({"set", "b", "offset", "3"}).exit_code, 0);
  EXPECT_EQ(cat("b")["parameters"]["offset"]["value"], "3");
  EXPECT_EQ(cat("a")["parameters"]["offset"]["value"], "0") << "each member has its own parameters";
  ASSERT_EQ(rtm({"off", "a"}).exit_code, 0);
  EXPECT_EQ(cat("a")["state"], "off");

  // SIGTERM: every member off and unbound, exit status 0.
  container.send_signal(SIGTERM);
  const auto status = container.wait_for_exit(10s);
  ASSERT_TRUE(status.has_value());
  EXPECT_TRUE(status->exited);
  EXPECT_EQ(status->code, 0) << container.output();
  EXPECT_NE(container.output().find("unbound a"), std::string::npos) << container.output();
  EXPECT_NE(container.output().find("unbound b"), std::string::npos) << container.output();
}

TEST_F(RtmContainer, ABadMemberIsRefusedBeforeAnythingStartsNamingIt) {
  struct Case {
    std::vector<std::vector<std::string>> members;
    int code;
    std::string says;
  };
  const std::vector<Case> cases{
      {{}, 2, "no members"},
      {{{"a"}}, 2, "want NAME PROGRAM"},
      {{{"a", TALKER_MODULE}, {"a", TALKER_MODULE}}, 2, "member a is given twice"},
      {{{"a/b", TALKER_MODULE}}, 2, "holds '/'"},
      {{{"a", TALKER_MODULE, "--fail-after", "soon"}}, 2, "--fail-after"},
      {{{"a", TALKER_MODULE, "--name", "z"}}, 2, "--name"},
      {{{"a", TALKER_MODULE, "-ORBtraceLevel", "10"}}, 2, "-ORB options go to rtm-container"},
      {{{"a", "/nonexistent/folder/rtm-nothing.so"}}, 1, "no module for /nonexistent/folder/rtm-nothing.so"},
      {{{"a", "rtm-nothing"}}, 1, "no module for rtm-nothing"},
  };
  for (const auto& c : cases) {
    const Outcome r = run(c.members);
    const std::string shown = c.members.empty() ? "(none)" : c.members[0][0];
    EXPECT_EQ(r.code, c.code) << shown << ": " << r.output;
    EXPECT_NE(r.output.find(c.says), std::string::npos) << shown << ": " << r.output;
    EXPECT_EQ(r.output.find("bound "), std::string::npos) << "something started: " << r.output;
  }
}

TEST_F(RtmContainer, AFileThatIsNoModuleOrThatOthersCouldHaveWrittenIsNotLoaded) {
  const fs::path dir = fs::temp_directory_path() / ("rtm-container-test-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path garbage = dir / "garbage.so";
  std::ofstream(garbage) << "not an ELF file\n";
  Outcome r = run({{"a", garbage.string()}});
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find(garbage.string()), std::string::npos) << r.output;

  const fs::path shared = dir / "talker.so";
  fs::copy_file(TALKER_MODULE, shared);
  fs::permissions(shared, fs::perms::others_write, fs::perm_options::add);
  r = run({{"a", shared.string()}});
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find("writable by others; not loaded"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("bound "), std::string::npos) << r.output;
  fs::remove_all(dir);
}

}  // namespace
