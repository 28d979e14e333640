// SPDX-License-Identifier: Apache-2.0
// A component process driven from outside: on/off repeated, state and timing through the
// extension interface.
#include "integration_fixture.h"

#include "rtm/inport.h"

#include <pwd.h>
#include <signal.h>
#include <sys/stat.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <thread>
#include <utility>
#include <vector>

namespace rtm_it {
namespace {

TEST_F(IntegrationTest, OnOffRepeatedLeavesTheComponentUsableAndCounting) {
  auto& process = start_component("cycler0");
  auto c = component("cycler0");
  for (int round = 0; round < 30; ++round) {
    c->on();
    ASSERT_EQ(c->state(), RTM::COMPONENT_ON) << "round " << round;
    c->on();  // idempotent
    c->off();
    ASSERT_EQ(c->state(), RTM::COMPONENT_OFF) << "round " << round;
    c->off();
  }
  c->on();
  const auto cycles = c->timing().cycles;
  ASSERT_TRUE(eventually([&] { return c->timing().cycles > cycles + 50; }));
  EXPECT_EQ(c->timing().period_ns, 2'000'000u);
  CORBA::String_var error = c->last_error();
  EXPECT_STREQ(error.in(), "");
  c->off();
  const auto stopped_at = c->timing().cycles;
  std::this_thread::sleep_for(50ms);
  EXPECT_EQ(c->timing().cycles, stopped_at) << "cycles ran while off";
  EXPECT_TRUE(process.running());
}

TEST_F(IntegrationTest, ComponentNameKindAndPortsAreVisibleRemotely) {
  start_component("intro0", {"--period", "5ms"});
  auto c = component("intro0");
  CORBA::String_var name = c->name();
  CORBA::String_var kind = c->kind();
  EXPECT_STREQ(name.in(), "intro0");
  EXPECT_STREQ(kind.in(), "test");
  RTM::InPortList_var ins = c->in_ports();
  RTM::OutPortList_var outs = c->out_ports();
  EXPECT_EQ(ins->length(), 2u);
  EXPECT_EQ(outs->length(), 2u);
  EXPECT_EQ(c->timing().period_ns, 5'000'000u);
}

// omniORB makes giop:unix: sockets 0777 unless told: a component's is its user's only, so other
// users come over TCP, where the access key decides (host/access.h).
TEST_F(IntegrationTest, AComponentsUnixSocketIsReadableAndWritableByItsUserOnly) {
  auto& process = start_component("private0");
  const std::string folder = "/tmp/omni-" + std::string(::getpwuid(::geteuid())->pw_name);
  char prefix[16];
  std::snprintf(prefix, sizeof prefix, "%09d-", static_cast<int>(process.pid()));
  int sockets = 0;
  for (const auto& entry : std::filesystem::directory_iterator(folder)) {
    if (entry.path().filename().string().rfind(prefix, 0) != 0) continue;
    ++sockets;
    struct stat st {};
    ASSERT_EQ(::stat(entry.path().c_str(), &st), 0);
    EXPECT_TRUE(S_ISSOCK(st.st_mode)) << entry.path();
    EXPECT_EQ(st.st_mode & 0777, 0600u) << entry.path();
  }
  EXPECT_EQ(sockets, 1) << "no socket of pid " << process.pid() << " in " << folder;
}

// Each thread of a process: its name and scheduling policy (/proc/<pid>/task/<tid>/stat).
std::vector<std::pair<std::string, int>> thread_policies(pid_t pid) {
  std::vector<std::pair<std::string, int>> threads;
  for (const auto& task : std::filesystem::directory_iterator("/proc/" + std::to_string(pid) + "/task")) {
    std::ifstream stat(task.path() / "stat");
    std::string text((std::istreambuf_iterator<char>(stat)), std::istreambuf_iterator<char>());
    const auto open = text.find('('), close = text.rfind(')');
    if (open == std::string::npos || close == std::string::npos) continue;
    std::istringstream fields(text.substr(close + 2));
    std::string field;
    for (int i = 3; i <= 41 && fields >> field; ++i) {
      if (i == 41) threads.emplace_back(text.substr(open + 1, close - open - 1), std::stoi(field));
    }
  }
  return threads;
}

TEST_F(IntegrationTest, StartedUnderChrtOnlyTheActivityKeepsRealTimePriorityOrbThreadsDoNot) {
  if (std::system("chrt -f 1 true >/dev/null 2>&1") != 0) GTEST_SKIP() << "SCHED_FIFO not allowed here";
  rtm_test::ChildProcess process({"chrt", "-f", "5", RTM_TEST_COMPONENT, "--name", "chrt0", "--naming",
                                  names_.address(), "--on"});
  process.wait_until_bound();
  // A few cycles: the activity has set its priority.
  ASSERT_TRUE(eventually([&] {
    for (const auto& [name, policy] : thread_policies(process.pid()))
      if (name == "chrt0" && policy == SCHED_FIFO) return true;
    return false;
  })) << "the activity never ran at SCHED_FIFO";
  int real_time = 0, others = 0;
  for (const auto& [name, policy] : thread_policies(process.pid())) {
    if (policy == SCHED_FIFO) {
      ++real_time;
      EXPECT_EQ(name, "chrt0") << "only the activity runs at SCHED_FIFO";
    } else {
      ++others;
    }
  }
  EXPECT_EQ(real_time, 1);
  EXPECT_GE(others, 2) << "the main thread and the ORB's";
  EXPECT_TRUE(process.stop().clean());
}

// The threads a datum passes on its way over CORBA run at the activity's priority: the thread
// serving a put from this user (the test runs as the component's user), and the delivery
// thread of a subscription. A read on the same connection is served at SCHED_OTHER again: only
// a put the access screen admitted gets the priority, so a caller who may only read cannot
// keep a real-time thread busy.
TEST_F(IntegrationTest, UnderChrtTheThreadsADatumPassesRunAtTheActivitysPriorityAndReadsDoNot) {
  if (std::system("chrt -f 1 true >/dev/null 2>&1") != 0) GTEST_SKIP() << "SCHED_FIFO not allowed here";
  // --shared-memory off: the subscription below goes over CORBA, through a delivery thread.
  rtm_test::ChildProcess process({"chrt", "-f", "7", RTM_TEST_COMPONENT, "--name", "chrt1", "--naming",
                                  names_.address(), "--shared-memory", "off"});
  process.wait_until_bound();
  // What runs at SCHED_FIFO besides the activity (named after the component), by name.
  const auto real_time_others = [&] {
    std::vector<std::string> names;
    for (const auto& [name, policy] : thread_policies(process.pid()))
      if (policy == SCHED_FIFO && name != "chrt1") names.push_back(name);
    return names;
  };
  ASSERT_TRUE(real_time_others().empty());
  auto c = component("chrt1");
  RTM::InPortList_var ins = c->in_ports();
  ASSERT_GT(ins->length(), 0u);
  CORBA::Any datum;
  datum <<= RTM::TimedFloat6{};
  ins[0]->put(datum);
  const std::vector<std::string> after_put = real_time_others();
  ASSERT_EQ(after_put.size(), 1u) << "the ORB thread that served the put";
  EXPECT_NE(after_put[0], "rtm-deliver");
  (void)c->state();  // a read, on the same connection
  EXPECT_TRUE(real_time_others().empty()) << "the read was served at SCHED_OTHER";

  PortableServer::Servant_var<rtm::InPort<RTM::TimedFloat6>> probe(
      new rtm::InPort<RTM::TimedFloat6>("probe", "itest", rtm::InPortPolicy::fifo(64)));
  RTM::InPortEx_var probe_ref = probe->activate(test_orb());
  RTM::OutPortList_var outs = c->out_ports();
  ASSERT_GT(outs->length(), 0u);
  ASSERT_TRUE(outs[0]->subscribe(RTM::repeated, probe_ref.in()));
  const std::vector<std::string> after_subscribe = real_time_others();
  EXPECT_EQ(std::count(after_subscribe.begin(), after_subscribe.end(), "rtm-deliver"), 1)
      << "the subscription's delivery thread";
  ASSERT_TRUE(outs[0]->unsubscribe(RTM::repeated, probe_ref.in()));
  probe->deactivate();
  EXPECT_TRUE(process.stop().clean());
}

// Open to all, a component does not know who puts: nobody's put gets a real-time thread.
TEST_F(IntegrationTest, UnderChrtAComponentOpenToAllServesPutsAtSchedOther) {
  if (std::system("chrt -f 1 true >/dev/null 2>&1") != 0) GTEST_SKIP() << "SCHED_FIFO not allowed here";
  rtm_test::ChildProcess process({"chrt", "-f", "7", RTM_TEST_COMPONENT, "--name", "chrt2", "--naming",
                                  names_.address(), "--access", "open"});
  process.wait_until_bound();
  auto c = component("chrt2");
  RTM::InPortList_var ins = c->in_ports();
  ASSERT_GT(ins->length(), 0u);
  CORBA::Any datum;
  datum <<= RTM::TimedFloat6{};
  ins[0]->put(datum);
  for (const auto& [name, policy] : thread_policies(process.pid()))
    EXPECT_TRUE(policy != SCHED_FIFO || name == "chrt2") << name << " runs at SCHED_FIFO";
  EXPECT_EQ(in_port("chrt2", "in0")->counters().accepted, 1u) << "the put went in";
  EXPECT_TRUE(process.stop().clean());
}

TEST_F(IntegrationTest, BadCommandLineIsOneErrorAndExitStatusTwo) {
  rtm_test::ChildProcess process({RTM_TEST_COMPONENT, "--period", "fast", "--naming", names_.address()});
  const auto status = process.wait_for_exit(10s);
  ASSERT_TRUE(status.has_value());
  EXPECT_TRUE(status->exited);
  EXPECT_EQ(status->code, 2);
  EXPECT_NE(process.output().find("period 'fast'"), std::string::npos) << process.output();
}

TEST_F(IntegrationTest, AnUnknownOptionIsOneErrorAndExitStatusTwo) {
  rtm_test::ChildProcess process({RTM_TEST_COMPONENT, "--no-such-option", "--naming", names_.address()});
  const auto status = process.wait_for_exit(10s);
  ASSERT_TRUE(status.has_value());
  EXPECT_TRUE(status->exited);
  EXPECT_EQ(status->code, 2) << process.output();
  EXPECT_NE(process.output().find("--no-such-option"), std::string::npos) << process.output();
}

TEST_F(IntegrationTest, AnUnknownDeliveryPolicyIsOneErrorNamingTheChoicesAndExitStatusTwo) {
  rtm_test::ChildProcess process({RTM_TEST_COMPONENT, "--delivery", "fast", "--naming", names_.address()});
  const auto status = process.wait_for_exit(10s);
  ASSERT_TRUE(status.has_value());
  EXPECT_EQ(status->code, 2) << process.output();
  EXPECT_NE(process.output().find("--delivery"), std::string::npos) << process.output();
  EXPECT_NE(process.output().find("writer"), std::string::npos) << "the choices are named: " << process.output();
}

TEST_F(IntegrationTest, TheValidateHookRefusesTheCommandLineWithExitStatusTwoBeforeAnythingStarts) {
  rtm_test::ChildProcess process(
      {RTM_TEST_COMPONENT, "--name", "twice0", "--also-bind", "twice0", "--naming", names_.address()});
  const auto status = process.wait_for_exit(10s);
  ASSERT_TRUE(status.has_value());
  EXPECT_EQ(status->code, 2) << process.output();
  EXPECT_NE(process.output().find("--also-bind twice0 is the component's own name"), std::string::npos)
      << process.output();
  EXPECT_FALSE(naming().is_bound(rtm::ComponentPath::on_this_host("twice0")));
}

TEST_F(IntegrationTest, NamesFromTheOnActivatedHookAreBoundBesideTheOwnAndUnboundAtExit) {
  auto& process = start_component("main0", {"--also-bind", "alias0", "--also-bind", "alias1"});
  process.wait_for_line("bound alias1", 10s);  // bound in order: main0, alias0, alias1
  for (const char* name : {"main0", "alias0", "alias1"}) {
    EXPECT_TRUE(naming().is_bound(rtm::ComponentPath::on_this_host(name))) << name;
  }
  auto alias = component("alias1");
  CORBA::String_var name = alias->name();
  EXPECT_STREQ(name.in(), "main0");  // the same component under another name
  process.send_signal(SIGTERM);
  const auto status = process.wait_for_exit(10s);
  ASSERT_TRUE(status.has_value());
  EXPECT_TRUE(status->clean()) << status->to_string();
  for (const char* gone : {"main0", "alias0", "alias1"}) {
    EXPECT_FALSE(naming().is_bound(rtm::ComponentPath::on_this_host(gone))) << gone;
  }
}

}  // namespace
}  // namespace rtm_it

namespace rtm_it {
namespace {

TEST_F(IntegrationTest, SigintStopsTheComponentAndUnbindsItsNameLikeSigterm) {
  auto& process = start_component("interrupted0", {"--on"});
  process.send_signal(SIGINT);
  const auto status = process.wait_for_exit(10s);
  ASSERT_TRUE(status.has_value()) << "no exit within 10 s after SIGINT";
  EXPECT_TRUE(status->clean()) << status->to_string();
  EXPECT_NE(process.output().find("stopping interrupted0 (SIGINT)"), std::string::npos) << process.output();
  EXPECT_FALSE(naming().is_bound(rtm::ComponentPath::on_this_host("interrupted0")));
}

TEST_F(IntegrationTest, OrbOptionsReachOmniOrbAndAnUnknownOneIsOneErrorWithExitStatusOne) {
  // A valid option passes through (omniORB then traces) and the component comes up.
  auto& traced = start_component("traced0", {"-ORBtraceLevel", "10"});
  EXPECT_GT(traced.count_lines("omniORB: "), 0u) << traced.output();
  rtm_test::ChildProcess bad({RTM_TEST_COMPONENT, "--name", "bad0", "--naming", names_.address(), "-ORBnoSuchOption", "1"});
  const auto status = bad.wait_for_exit(10s);
  ASSERT_TRUE(status.has_value());
  EXPECT_TRUE(status->exited) << status->to_string();
  EXPECT_EQ(status->code, 1);
  EXPECT_NE(bad.output().find("ORB initialisation failed"), std::string::npos) << bad.output();
  EXPECT_FALSE(naming().is_bound(rtm::ComponentPath::on_this_host("bad0")));
}

}  // namespace
}  // namespace rtm_it
