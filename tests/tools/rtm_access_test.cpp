// SPDX-License-Identifier: Apache-2.0
// Access control against another local user (docs/safety.md), tried as an attacker would: a
// bait bound under a name in the owner's naming service records what the owner's tools send
// it, and every request is then replayed to change the owner's component; changes over a
// connection where the caller cannot be told; wiring from a writer that could never deliver;
// `rtm up` and a name bound to an impostor. The real rtm, real components, real omniNames.
#include "rtm_test/run_command.h"

#include "host/access.h"
#include "rtm/naming.h"
#include "rtm/orb.h"
#include "rtm_test/child_process.h"
#include "rtm_test/omni_names.h"
#include "rtm_test/raw_giop.h"

#include <gtest/gtest.h>
#include <httplib.h>
#include <nlohmann/json.hpp>

#include <unistd.h>

#include <filesystem>
#include <functional>
#include <fstream>
#include <memory>
#include <set>
#include <thread>

namespace {

using nlohmann::json;
using rtm_test::ChildProcess;
using rtm_test::CommandResult;
using rtm_test::OmniNames;
using namespace std::chrono_literals;
namespace fs = std::filesystem;

rtm::Orb& test_orb() {
  static rtm::Orb orb;  // omniORB: one ORB per process
  return orb;
}

class RtmAccess : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("rtm-access-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    talkers_.clear();
    fs::remove_all(dir_);
  }
  CommandResult rtm(std::vector<std::string> args, std::vector<std::string> env = {}) {
    args.insert(args.begin(), {RTM_CLI_PATH, "--naming", names_.address()});
    env.push_back("RTM_BIN_PATH=" + std::string(RTM_TEST_BIN_DIR));
    env.push_back("XDG_RUNTIME_DIR=" + dir_.string());
    return rtm_test::run_command(args, env, std::chrono::seconds(30));
  }
  json rtm_json(std::vector<std::string> args) {
    args.insert(args.begin(), "--json");
    const CommandResult r = rtm(args);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return r.exit_code == 0 ? json::parse(r.out) : json();
  }
  ChildProcess& talker(const std::string& name, std::vector<std::string> extra = {},
                       std::vector<std::string> prefix = {}) {
    std::vector<std::string> argv = prefix;
    argv.insert(argv.end(), {TALKER_PATH, "--name", name, "--naming", names_.address()});
    argv.insert(argv.end(), extra.begin(), extra.end());
    return rtm_test::start_bound(talkers_, argv);
  }
  std::string state_of(const std::string& name) {
    for (const auto& c : rtm_json({"ls"}))
      if (c["name"] == name) return c.value("state", "?");
    return "absent";
  }
  static const json* port_of(const json& component, const std::string& name) {
    for (const auto& p : component["ports"])
      if (p["name"] == name) return &p;
    return nullptr;
  }
  rtm::NamingClient naming() { return rtm::NamingClient(test_orb().orb(), rtm::NamingAddress::parse(names_.address())); }
  std::string alpha_ior() {
    CORBA::Object_var object = naming().resolve_object(rtm::ComponentPath::on_this_host("alpha"));
    return test_orb().to_string(object.in());
  }
  static std::string fmt_context(const rtm_test::ServiceContext& c) {
    std::string text = std::to_string(c.id) + ":";
    static constexpr char kHex[] = "0123456789abcdef";
    for (std::uint8_t b : c.data) text += {kHex[b >> 4], kHex[b & 15]};
    return text;
  }
  static bool root_with_setpriv() { return ::geteuid() == 0 && ::access("/usr/bin/setpriv", X_OK) == 0; }
  static std::vector<std::string> as_nobody() {
    return {"/usr/bin/setpriv", "--reuid=65534", "--regid=65534", "--clear-groups", "--"};
  }

  OmniNames names_;
  fs::path dir_;
  std::vector<std::unique_ptr<ChildProcess>> talkers_;
};

// The owner's `rtm ls`, `rtm cat`, `rtm up` (and the component it starts) and `rtm serve` all
// call a bait someone bound under a name. Whatever they send it, replayed to the owner's
// component as a request to turn it off, changes nothing: no credential is on the wire.
TEST_F(RtmAccess, AnotherUserWhoBindsANameLearnsNothingFromLsUpOrServeThatChangesAComponent) {
  talker("alpha", {"--on"});
  rtm_test::GiopRecorder bait;
  CORBA::Object_var bait_ref = test_orb().from_string(bait.corbaloc());
  naming().bind(rtm::ComponentPath::on_this_host("bait"), bait_ref.in());
  naming().bind(rtm::ComponentPath::on_this_host("decoy"), bait_ref.in());

  EXPECT_EQ(rtm({"ls"}).exit_code, 0);
  EXPECT_EQ(rtm({"ls", "-l"}).exit_code, 0);
  rtm({"cat", "bait"});
  // rtm up of a system naming the bait's name: rtm and the component it starts look it up.
  const fs::path system = dir_ / "baited.yaml";
  std::ofstream(system) << "name: baited\ncomponents:\n  - {name: bait, command: rtm-test-talker}\nactivate: [bait]\n";
  rtm({"up", system.string()});
  rtm({"down", "baited"});
  // rtm serve polls every listed component for the page.
  ChildProcess::Options quiet;
  quiet.echo_output = false;
  ChildProcess serve({RTM_CLI_PATH, "--naming", names_.address(), "serve", "--listen", "127.0.0.1:0"}, quiet);
  std::string url = serve.wait_for_line("http://", 10s);
  url = url.substr(url.find("http://"));
  const auto port_start = url.find(':', 7) + 1;
  httplib::Client page("127.0.0.1", std::stoi(url.substr(port_start, url.find('/', port_start) - port_start)));
  const std::string token = url.substr(url.find("#token=") + 7);
  const auto system_answer = page.Get("/api/system", {{"X-RTM-Token", token}});
  ASSERT_TRUE(system_answer) << "rtm serve did not answer";
  EXPECT_EQ(system_answer->status, 200) << system_answer->body;
  serve.stop();

  const auto requests = bait.requests();
  ASSERT_FALSE(requests.empty()) << "nothing called the bait: the test proves nothing";
  std::set<std::vector<rtm_test::ServiceContext>> context_sets;
  for (const auto& r : requests) {
    context_sets.insert(r.contexts);
    for (const auto& c : r.contexts)
      EXPECT_NE(c.id & 0xffffff00u, 0x52544d00u) << r.operation << " carried a context of RTM's own: a credential";
  }
  context_sets.insert({});
  if (!root_with_setpriv()) GTEST_SKIP() << "replaying as the user nobody needs root and setpriv";
  // The attacker replays each set of service contexts it saw to turn alpha off, as it reaches
  // alpha: over TCP on loopback (its giop:unix: socket is the owner's alone).
  const std::string alpha = alpha_ior();
  for (const auto& contexts : context_sets) {
    std::vector<std::string> argv = as_nobody();
    argv.insert(argv.end(), {REPLAY_PATH, alpha, "off"});
    for (const auto& c : contexts) argv.push_back(fmt_context(c));
    const CommandResult replay = rtm_test::run_command(argv);
    EXPECT_NE(replay.out.find("reply 2 IDL:omg.org/CORBA/NO_PERMISSION:1.0"), std::string::npos)
        << "a replayed off was not refused: " << replay.out << replay.err;
  }
  EXPECT_EQ(state_of("alpha"), "on") << "a replayed request turned the owner's component off";
}

// omniORB falls back from giop:unix: to TCP when a call on the socket fails (a timeout under
// load): over TCP on this host the kernel names the caller just the same (/proc/net/tcp), so
// the owner's changes still go through, and another user's still do not.
TEST_F(RtmAccess, OverTcpOnThisHostTheCallerIsKnownAsOverUnixTheOwnersChangesPass) {
  talker("alpha", {"--on"});
  talker("beta");
  const std::vector<std::string> tcp_only{"ORBclientTransportRule=* tcp"};
  EXPECT_EQ(rtm({"off", "alpha"}, tcp_only).exit_code, 0);
  EXPECT_EQ(rtm({"connect", "alpha.force", "beta.in0"}, tcp_only).exit_code, 0);
  EXPECT_EQ(rtm({"put", "beta.in0", "0", "0", "1", "0", "0", "0"}, tcp_only).exit_code, 0);
  EXPECT_EQ(state_of("alpha"), "off");
  const json beta = rtm_json({"cat", "beta"});
  EXPECT_EQ((*port_of(beta, "in0"))["counters"]["accepted"], 1) << beta.dump();
  if (!root_with_setpriv()) GTEST_SKIP() << "the user nobody's side needs root and setpriv";
  std::vector<std::string> argv = as_nobody();
  argv.insert(argv.end(), {RTM_CLI_PATH, "--naming", names_.address(), "on", "alpha"});
  const CommandResult nobody = rtm_test::run_command(argv, {"HOME=/nonexistent", "ORBclientTransportRule=* tcp"});
  EXPECT_NE(nobody.exit_code, 0);
  EXPECT_NE(nobody.err.find("not allowed: only the user who started it may change it"), std::string::npos)
      << nobody.err;
  EXPECT_EQ(state_of("alpha"), "off");
}

// From another host over plain TCP nobody can tell who calls: a change is refused, with a
// sentence. The other host is a network namespace of its own (needs root and iproute2).
TEST_F(RtmAccess, ACallerFromAnotherHostOverPlainTcpChangesNothing) {
  if (::geteuid() != 0 || (::access("/usr/bin/ip", X_OK) != 0 && ::access("/sbin/ip", X_OK) != 0))
    GTEST_SKIP() << "another host in a network namespace needs root and ip";
  const std::string ns = "rtmacc" + std::to_string(::getpid());
  const std::string near = "ra" + std::to_string(::getpid() % 100000), far = "rb" + std::to_string(::getpid() % 100000);
  const auto sh = [](const std::string& command) { return rtm_test::run_command({"/bin/sh", "-c", command}); };
  if (sh("ip netns add " + ns).exit_code != 0) GTEST_SKIP() << "no network namespaces here";
  struct Cleanup {
    std::function<void()> f;
    ~Cleanup() { f(); }
  } cleanup{[&] { sh("ip link del " + near + "; ip netns del " + ns); }};
  ASSERT_EQ(sh("ip link add " + near + " type veth peer name " + far + " && ip link set " + far + " netns " + ns +
               " && ip addr add 10.231.7.1/30 dev " + near + " && ip link set " + near + " up && ip -n " + ns +
               " addr add 10.231.7.2/30 dev " + far + " && ip -n " + ns + " link set " + far + " up")
                .exit_code,
            0);
  talker("alpha", {"--on", "--endpoint", "giop:tcp:10.231.7.1:", "--endpoint", "giop:unix:"});
  const CommandResult replay =
      rtm_test::run_command({"ip", "netns", "exec", ns, REPLAY_PATH, alpha_ior(), "off"});
  EXPECT_NE(replay.out.find("reply 2 IDL:omg.org/CORBA/NO_PERMISSION:1.0 " + std::to_string(rtm::kCallerUnknownMinor)),
            std::string::npos)
      << replay.out << replay.err;
  EXPECT_EQ(state_of("alpha"), "on");
}

// The owner's own processes on the host need no key file or anything else: the kernel says who
// they are.
TEST_F(RtmAccess, TheOwnersProcessesChangeComponentsWithoutAnyFileOfTheirOwn) {
  talker("alpha", {"--on"});
  const CommandResult off = rtm({"off", "alpha"}, {"HOME=/nonexistent"});
  EXPECT_EQ(off.exit_code, 0) << off.err;
  EXPECT_EQ(state_of("alpha"), "off");
}

// A component started with --access open (for 2004 clients) is still its user's process: its
// data into that user's owner-only components arrive.
TEST_F(RtmAccess, AComponentOpenToAllWiredIntoAnOwnerOnlyOneDeliversItsData) {
  talker("open0", {"--access", "open", "--on", "--period", "5ms"});
  talker("closed0");
  const CommandResult connect = rtm({"connect", "open0.force", "closed0.in0"});
  ASSERT_EQ(connect.exit_code, 0) << connect.err;
  json in0;
  for (int i = 0; i < 100; ++i) {
    in0 = *port_of(rtm_json({"cat", "closed0"}), "in0");
    if (in0["counters"]["accepted"].get<std::uint64_t>() > 0) break;
    std::this_thread::sleep_for(20ms);
  }
  EXPECT_GT(in0["counters"]["accepted"].get<std::uint64_t>(), 0u) << in0.dump();
  EXPECT_EQ(in0["counters"]["rejected"], 0);
}

// A writer another user runs, wired into the owner's component: each of its puts would be
// refused, so the wiring is refused at connect with the reason, instead of "connected" and
// silence (needs root to switch user; skipped otherwise).
TEST_F(RtmAccess, AnotherUsersComponentWiredIntoTheOwnersIsRefusedAtConnectWithTheReason) {
  if (!root_with_setpriv()) GTEST_SKIP() << "switching to the user nobody needs root and setpriv";
  talker("reader0");
  talker("foreign0", {"--on"}, as_nobody());
  const CommandResult connect = rtm({"connect", "foreign0.force", "reader0.in0"});
  EXPECT_NE(connect.exit_code, 0) << connect.out;
  EXPECT_NE(connect.err.find("foreign0.force -> reader0.in0"), std::string::npos) << connect.err;
  EXPECT_NE(connect.err.find("not allowed: only the user who started it may change it"), std::string::npos)
      << connect.err;
  const json foreign = rtm_json({"cat", "foreign0"});
  EXPECT_TRUE((*port_of(foreign, "force"))["subscriptions"].empty()) << foreign.dump();
  const json reader = rtm_json({"cat", "reader0"});
  EXPECT_EQ((*port_of(reader, "in0"))["counters"]["accepted"], 0);
}

// `rtm up` asks the kernel which process serves the name, not the object: an impostor that
// binds the name and claims the started process's pid is found out.
TEST_F(RtmAccess, UpFindsOutAnImpostorThatClaimsThePidOfTheProcessItStarted) {
  const fs::path system = dir_ / "claimed.yaml";
  // The started process (a shell, then sleep) is no component; a child of it binds the name
  // and says it is that process.
  std::ofstream(system) << "name: claimed\ncomponents:\n  - name: a\n    command: [sh, -c, '" IMPOSTOR_PATH
                           " --claim-pid $$ \"$@\" & exec sleep 30', sh]\n";
  const CommandResult up = rtm({"up", system.string(), "--bind-timeout", "10000"});
  EXPECT_NE(up.exit_code, 0) << up.out;
  EXPECT_NE(up.err.find("a is bound to another process"), std::string::npos) << up.err;
  rtm({"down", "claimed"});
}

// omniNames lets anyone bind any name: one bound by hand with terminal controls in it is shown
// escaped and marked, never acted on by the owner's terminal.
TEST_F(RtmAccess, ANameBoundByHandIsListedEscapedAndMarkedNeverAsTerminalControls) {
  talker("alpha");
  CORBA::Object_var alpha = naming().resolve_object(rtm::ComponentPath::on_this_host("alpha"));
  naming().bind({rtm::local_host_name(), "\x1b]0;owned\x07\x1b[2J<img src=x>"}, alpha.in());
  for (const std::vector<std::string>& command : {std::vector<std::string>{"ls"}, {"ls", "-l"}, {"ls", "--names"}}) {
    const CommandResult r = rtm(command);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(r.out.find('\x1b'), std::string::npos) << command.back() << ": a raw escape reached the terminal";
    EXPECT_NE(r.out.find("\\x1b]0;owned\\x07\\x1b[2J<img src=x>"), std::string::npos) << r.out;
  }
  EXPECT_NE(rtm({"ls"}).out.find("(not a valid name)"), std::string::npos);
  const json listed = rtm_json({"ls"});
  bool marked = false;
  for (const auto& c : listed)
    if (c["name"] != "alpha") marked = c["name_ok"] == false;
  EXPECT_TRUE(marked) << listed.dump();
}

}  // namespace
