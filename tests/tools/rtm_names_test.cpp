// SPDX-License-Identifier: Apache-2.0
// `rtm names`: a naming service of the user's own on loopback, started once, reused while it
// runs, replaced when it died, stopped with its data; its folder this user's alone.
#include "rtm_test/free_port.h"
#include "rtm_test/run_command.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <signal.h>
#include <stdlib.h>
#include <sys/stat.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

namespace {

namespace fs = std::filesystem;
using rtm_test::CommandResult;

class RtmNames : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string pattern = (fs::temp_directory_path() / "rtm-names-test-XXXXXX").string();
    ASSERT_NE(::mkdtemp(pattern.data()), nullptr);
    runtime_ = pattern;
  }
  void TearDown() override {
    rtm({"names", "--stop"});  // whatever a test left running
    fs::remove_all(runtime_);
  }
  CommandResult rtm(std::vector<std::string> args) const {
    args.insert(args.begin(), RTM_CLI_PATH);
    return rtm_test::run_command(args, {"XDG_RUNTIME_DIR=" + runtime_.string()}, std::chrono::seconds(30));
  }
  // The address of `export RTM_NAMING=127.0.0.1:<port>`, "" unless out is that line alone.
  static std::string exported(const std::string& out) {
    const std::string prefix = "export RTM_NAMING=";
    if (out.rfind(prefix, 0) != 0 || out.back() != '\n') return "";
    const std::string address = out.substr(prefix.size(), out.size() - prefix.size() - 1);
    const std::string host = "127.0.0.1:";
    if (address.rfind(host, 0) != 0 || address.size() == host.size() ||
        address.find_first_not_of("0123456789", host.size()) != std::string::npos)
      return "";
    return address;
  }
  static std::uint16_t port_of(const std::string& address) {
    return static_cast<std::uint16_t>(std::stoi(address.substr(address.rfind(':') + 1)));
  }
  fs::path runtime_;
};

TEST_F(RtmNames, StartsOneOnLoopbackThatRtmUsesReusesItAndStopsIt) {
  const CommandResult first = rtm({"names"});
  ASSERT_EQ(first.exit_code, 0) << first.err;
  const std::string address = exported(first.out);
  ASSERT_FALSE(address.empty()) << "stdout is the shell line alone: " << first.out;
  EXPECT_NE(first.err.find("naming service started on " + address), std::string::npos) << first.err;
  EXPECT_TRUE(rtm_test::loopback_port_accepts(port_of(address)));
  const CommandResult ls = rtm({"--naming", address, "ls"});
  EXPECT_EQ(ls.exit_code, 0) << "rtm reaches it: " << ls.err;

  const CommandResult again = rtm({"--json", "names"});
  ASSERT_EQ(again.exit_code, 0) << again.err;
  const auto j = nlohmann::json::parse(again.out);
  EXPECT_EQ(j["address"], address) << "the running one is reused";
  EXPECT_EQ(j["started"], false);

  const CommandResult stop = rtm({"names", "--stop"});
  EXPECT_EQ(stop.exit_code, 0) << stop.err;
  EXPECT_NE(stop.out.find("stopped the naming service on " + address), std::string::npos) << stop.out;
  EXPECT_FALSE(rtm_test::loopback_port_accepts(port_of(address))) << "stopped before --stop returned";
  EXPECT_FALSE(fs::exists(runtime_ / "rtm" / "names")) << "its data removed";
  EXPECT_NE(rtm({"names", "--stop"}).out.find("no naming service of yours was running"), std::string::npos);
}

TEST_F(RtmNames, TwoStartedAtOnceGiveOneService) {
  CommandResult first, second;
  std::thread other([&] { first = rtm({"names"}); });
  second = rtm({"names"});
  other.join();
  ASSERT_EQ(first.exit_code, 0) << first.err;
  ASSERT_EQ(second.exit_code, 0) << second.err;
  EXPECT_EQ(exported(first.out), exported(second.out)) << first.err << second.err;
  EXPECT_EQ((first.err + second.err).find("started") != std::string::npos &&
                (first.err + second.err).find("running") != std::string::npos,
            true)
      << "one started it, the other found it running: " << first.err << second.err;
}

TEST_F(RtmNames, OneThatDiedIsReplacedByAFreshOne) {
  const CommandResult first = rtm({"--json", "names"});
  ASSERT_EQ(first.exit_code, 0) << first.err;
  const auto j = nlohmann::json::parse(first.out);
  const std::string address = j["address"];
  ASSERT_EQ(::kill(j["pid"].get<pid_t>(), SIGKILL), 0);
  for (int i = 0; i < 500 && rtm_test::loopback_port_accepts(port_of(address)); ++i) ::usleep(10'000);

  const CommandResult second = rtm({"names"});
  ASSERT_EQ(second.exit_code, 0) << second.err;
  EXPECT_NE(second.err.find("naming service started on"), std::string::npos) << second.err;
  const std::string fresh = exported(second.out);
  ASSERT_FALSE(fresh.empty()) << second.out;
  EXPECT_TRUE(rtm_test::loopback_port_accepts(port_of(fresh)));
}

TEST_F(RtmNames, ItsFolderIsThisUsersAloneALinkIsRefusedAndAnOpenOneClosed) {
  const fs::path elsewhere = runtime_ / "elsewhere";
  fs::create_directories(elsewhere);
  fs::create_directory_symlink(elsewhere, runtime_ / "rtm");
  const CommandResult linked = rtm({"names"});
  EXPECT_EQ(linked.exit_code, 1);
  EXPECT_NE(linked.err.find("is not a folder of this user's"), std::string::npos) << linked.err;
  EXPECT_TRUE(fs::is_empty(elsewhere)) << "nothing started or written through the link";

  fs::remove(runtime_ / "rtm");
  fs::create_directory(runtime_ / "rtm");
  fs::permissions(runtime_ / "rtm", fs::perms::all);
  const CommandResult open = rtm({"names"});
  ASSERT_EQ(open.exit_code, 0) << open.err;
  struct stat st {};
  ASSERT_EQ(::stat((runtime_ / "rtm").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0700u) << "closed to other users before anything was kept there";
}

}  // namespace
