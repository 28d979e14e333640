// SPDX-License-Identifier: Apache-2.0
// The naming service as a component sees it: bound where OpenRTM looks, unbound on SIGTERM,
// re-bound after the service restarts, one error line while it is away.
#include "integration_fixture.h"

#include "rtm_test/free_port.h"

#include <signal.h>

#include <thread>

namespace rtm_it {
namespace {

using rtm::ComponentPath;
using rtm::NamingAddress;
using rtm::NamingClient;
using rtm::NamingError;

TEST_F(IntegrationTest, ComponentIsBoundAtHostContextSlashNameRtc) {
  auto& process = start_component("bindme0");
  const auto line = process.wait_until_bound();
  const auto path = ComponentPath::on_this_host("bindme0");
  EXPECT_NE(line.find("bound bindme0 at " + path.to_string() + " via " + names_.address()), std::string::npos)
      << line;

  auto entries = naming().list_components();
  ASSERT_EQ(entries.size(), 1u);
  EXPECT_EQ(entries[0].path, path);
  EXPECT_TRUE(naming().is_bound(path));
}

TEST_F(IntegrationTest, ResolvesBareNameAndHostSlashNameToTheSameComponent) {
  start_component("alpha0");
  start_component("beta0");
  auto by_name = naming().resolve_component("alpha0");
  auto by_path = naming().resolve_component(rtm::local_host_name() + "/alpha0");
  EXPECT_TRUE(by_name->_is_equivalent(by_path));
  auto other = naming().resolve_component("beta0");
  EXPECT_FALSE(by_name->_is_equivalent(other));
  EXPECT_EQ(naming().list_components().size(), 2u);
}

TEST_F(IntegrationTest, ResolvingAnUnknownNameSaysWhichNameAndWhere) {
  start_component("known0");
  try {
    naming().resolve_component("unknown0");
    FAIL() << "resolve of an unbound name returned";
  } catch (const NamingError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown0"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(names_.address()), std::string::npos) << e.what();
  }
  EXPECT_THROW(naming().resolve_component("nohost/known0"), NamingError);
}

TEST_F(IntegrationTest, SigtermUnbindsTheNameAndExitsCleanly) {
  auto& process = start_component("leaving0");
  const auto path = ComponentPath::on_this_host("leaving0");
  ASSERT_TRUE(naming().is_bound(path));
  process.send_signal(SIGTERM);
  const auto status = process.wait_for_exit(10s);
  ASSERT_TRUE(status.has_value()) << "no exit within 10 s after SIGTERM";
  EXPECT_TRUE(status->clean()) << status->to_string() << "\n" << process.output();
  EXPECT_FALSE(naming().is_bound(path));
}

// One name, one component: a second process of the same name is refused at start while the
// first answers, instead of taking the name and losing it again at the first's next check.
TEST_F(IntegrationTest, ASecondComponentOfTheSameNameIsRefusedWhileTheFirstAnswers) {
  auto& first = start_component("twin0");
  const auto path = ComponentPath::on_this_host("twin0");
  CORBA::Object_var held = naming().resolve_object(path);
  rtm_test::ChildProcess second({RTM_TEST_COMPONENT, "--name", "twin0", "--naming", names_.address()});
  const auto status = second.wait_for_exit(10s);
  ASSERT_TRUE(status.has_value()) << "the second twin0 kept running";
  EXPECT_EQ(status->code, 1) << second.output();
  EXPECT_NE(second.output().find("names another component, which answers"), std::string::npos) << second.output();
  // Several of the first's checks later the name still leads to it, never re-bound.
  std::this_thread::sleep_for(1500ms);
  CORBA::Object_var now = naming().resolve_object(path);
  EXPECT_TRUE(now->_is_equivalent(held.in())) << "the name changed hands";
  EXPECT_EQ(first.count_lines("re-bound"), 0u) << first.output();
  component("twin0")->on();
  EXPECT_EQ(component("twin0")->state(), RTM::COMPONENT_ON);
}

// A binding left by a component that was killed (it cannot unbind) does not block its
// successor: a name whose component no longer answers is taken over.
TEST_F(IntegrationTest, ANameWhoseComponentNoLongerAnswersIsTakenOver) {
  auto& first = start_component("phoenix2");
  const auto killed = first.kill_now();
  EXPECT_FALSE(killed.clean());
  ASSERT_TRUE(naming().is_bound(ComponentPath::on_this_host("phoenix2"))) << "SIGKILL left the binding";
  auto& second = start_component("phoenix2");
  EXPECT_EQ(second.count_lines("in place of a component that no longer answers"), 1u) << second.output();
  component("phoenix2")->on();
  EXPECT_EQ(component("phoenix2")->state(), RTM::COMPONENT_ON);
}

TEST_F(IntegrationTest, ComponentsRebindAfterNamingServiceRestartsWithoutItsData) {
  auto& a = start_component("phoenix0");
  auto& b = start_component("phoenix1");
  names_.restart(rtm_test::OmniNames::Data::fresh);
  a.wait_for_line("re-bound phoenix0", 10s);
  b.wait_for_line("re-bound phoenix1", 10s);
  EXPECT_TRUE(naming().is_bound(ComponentPath::on_this_host("phoenix0")));
  EXPECT_TRUE(naming().is_bound(ComponentPath::on_this_host("phoenix1")));
  // The re-bound reference is the live component.
  auto phoenix = component("phoenix0");
  phoenix->on();
  EXPECT_EQ(phoenix->state(), RTM::COMPONENT_ON);
}

TEST_F(IntegrationTest, ComponentRebindsWhenNamingServiceComesBackAfterAnOutage) {
  auto& a = start_component("patient0");
  names_.stop();
  a.wait_for_line("unreachable", 10s);
  names_.start(rtm_test::OmniNames::Data::keep);
  a.wait_for_line("re-bound patient0", 10s);
  EXPECT_TRUE(naming().is_bound(ComponentPath::on_this_host("patient0")));
}

TEST_F(IntegrationTest, NamingServiceDownAtStartIsOneErrorLineAndTheComponentBindsLater) {
  names_.stop();
  rtm_test::ChildProcess process({RTM_TEST_COMPONENT, "--name", "early0", "--naming", names_.address()});
  const auto line = process.wait_for_line("unreachable", 10s);
  EXPECT_NE(line.find("naming service at " + names_.address() + " unreachable: TRANSIENT"), std::string::npos)
      << line;
  // Several check intervals later: still one line, still running.
  std::this_thread::sleep_for(1500ms);
  EXPECT_EQ(process.count_lines("unreachable"), 1u) << process.output();
  ASSERT_TRUE(process.running()) << process.output();

  names_.start(rtm_test::OmniNames::Data::fresh);
  process.wait_for_line("bound early0", 10s);
  EXPECT_TRUE(naming().is_bound(ComponentPath::on_this_host("early0")));
  const auto status = process.stop();
  EXPECT_TRUE(status.clean()) << status.to_string();
}

TEST(NamingClientTest, UnreachableServiceIsANamingErrorNamingTheAddress) {
  const auto port = rtm_test::free_loopback_port();
  NamingClient client(test_orb().orb(), NamingAddress{"127.0.0.1", port});
  try {
    client.list_components();
    FAIL() << "list_components on a dead address returned";
  } catch (const NamingError& e) {
    EXPECT_EQ(std::string(e.what()), "naming service at 127.0.0.1:" + std::to_string(port) + " unreachable: TRANSIENT");
  }
}

}  // namespace
}  // namespace rtm_it
