// SPDX-License-Identifier: Apache-2.0
// The runner's and the naming API's value parsing: periods, -ORB pass-through, naming
// addresses and component paths. No ORB, no processes.
#include "rtm/naming.h"
#include "host/runner.h"

#include <gtest/gtest.h>

#include <stdexcept>

namespace {

using rtm::ComponentPath;
using rtm::NamingAddress;

TEST(ParsePeriod, AcceptsMillisecondsMicrosecondsNanosecondsAndSeconds) {
  EXPECT_EQ(rtm::parse_period_ns("2ms"), 2'000'000);
  EXPECT_EQ(rtm::parse_period_ns("500us"), 500'000);
  EXPECT_EQ(rtm::parse_period_ns("250000ns"), 250'000);
  EXPECT_EQ(rtm::parse_period_ns("0.002s"), 2'000'000);
  EXPECT_EQ(rtm::parse_period_ns("0.002"), 2'000'000);
  EXPECT_EQ(rtm::parse_period_ns("1.5ms"), 1'500'000);
}

TEST(ParsePeriod, RejectsWhatIsNotADurationFrom50usTo1hNamingTheText) {
  for (const char* bad : {"", "ms", "fast", "-2ms", "0", "0ns", "1ns", "49us", "2 ms", "2min", "1e12s", "nan", "infs"}) {
    try {
      rtm::parse_period_ns(bad);
      ADD_FAILURE() << "'" << bad << "' was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("'") + bad + "'"), std::string::npos) << e.what();
    }
  }
}

TEST(ParsePhase, AcceptsZeroToLessThanThePeriodAndRefusesTheRestNamingIt) {
  EXPECT_EQ(rtm::parse_phase_ns("0", 2'000'000), 0);
  EXPECT_EQ(rtm::parse_phase_ns("0.5ms", 2'000'000), 500'000);
  EXPECT_EQ(rtm::parse_phase_ns("1999us", 2'000'000), 1'999'000);
  for (const char* bad : {"2ms", "3ms", "-1us", "soon", "", "nan"}) {
    try {
      rtm::parse_phase_ns(bad, 2'000'000);
      ADD_FAILURE() << "'" << bad << "' was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("'") + bad + "'"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("less than the period (2000 us)"), std::string::npos) << e.what();
    }
  }
}

// With a phase, every start joins the grid k * period + phase; without, it starts at once.
TEST(ParseAwait, TakesAPortWithABoundOrATenthOfThePeriodAndRefusesABoundOutsideIt) {
  EXPECT_EQ(rtm::parse_await("wrench:0.2ms", 2'000'000), (std::pair<std::string, std::int64_t>{"wrench", 200'000}));
  EXPECT_EQ(rtm::parse_await("in0", 2'000'000), (std::pair<std::string, std::int64_t>{"in0", 200'000}));
  for (const char* bad : {":0.2ms", "in0:0", "in0:2ms", "in0:-1us", "in0:soon"}) {
    try {
      rtm::parse_await(bad, 2'000'000);
      ADD_FAILURE() << bad << " was taken";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
    }
  }
}

TEST(RunSettings, APhasePutsTheFirstDeadlineOnTheGridOfThePeriod) {
  rtm::RunSettings settings;
  settings.period_ns = 2'000'000;
  EXPECT_EQ(settings.periodic_options().first_deadline_ns, 0);
  settings.phase_ns = 500'000;
  const std::int64_t first = settings.periodic_options().first_deadline_ns;
  EXPECT_EQ(first % 2'000'000, 500'000);
  EXPECT_GT(first, 0);
}

TEST(SplitOrbArguments, TakesEachOrbOptionWithItsValueAndKeepsTheRestInOrder) {
  const char* argv[] = {"prog", "--name", "s0", "-ORBtraceLevel", "10", "--on", "-ORBendPoint", "giop:unix:", "x"};
  const auto split = rtm::split_orb_arguments(9, argv);
  EXPECT_EQ(split.own, (std::vector<std::string>{"prog", "--name", "s0", "--on", "x"}));
  EXPECT_EQ(split.orb, (std::vector<std::string>{"-ORBtraceLevel", "10", "-ORBendPoint", "giop:unix:"}));
}

TEST(SplitOrbArguments, LeavesProgramNameAndLookalikesAlone) {
  const char* argv[] = {"-ORBprog", "-ORB", "--ORBx", "1"};
  const auto split = rtm::split_orb_arguments(4, argv);
  EXPECT_EQ(split.own, (std::vector<std::string>{"-ORBprog", "-ORB", "--ORBx", "1"}));
  EXPECT_TRUE(split.orb.empty());
}

TEST(RunSettings, PeriodicOptionsCarryPeriodPriorityCpuMemoryLockAndName) {
  rtm::RunSettings settings;
  settings.name = "sensor0";
  settings.period_ns = 1'000'000;
  settings.rt_priority = 20;
  settings.cpu = 1;
  settings.lock_memory = true;
  const auto options = settings.periodic_options();
  EXPECT_EQ(options.period_ns, 1'000'000);
  EXPECT_EQ(options.fifo_priority, 20);
  EXPECT_EQ(options.cpu, 1);
  EXPECT_TRUE(options.lock_memory);
  EXPECT_EQ(options.thread_name, "sensor0");
}

TEST(NamingAddressParse, HostPortHostAloneAndBracketedIpv6) {
  EXPECT_EQ(NamingAddress::parse("10.0.0.1:2900"), (NamingAddress{"10.0.0.1", 2900}));
  EXPECT_EQ(NamingAddress::parse("example"), (NamingAddress{"example", 2809}));
  EXPECT_EQ(NamingAddress::parse("[::1]:2810"), (NamingAddress{"::1", 2810}));
  EXPECT_EQ(NamingAddress::parse("[::1]:2810").to_string(), "[::1]:2810");
  EXPECT_EQ(NamingAddress{}.corbaloc(), "corbaloc::127.0.0.1:2809/NameService");
}

TEST(NamingAddressParse, RejectsEmptyHostAndBadPorts) {
  for (const char* bad : {"", ":2809", "host:", "host:http", "host:0", "host:70000", "[::1", "[::1]x"}) {
    EXPECT_THROW(NamingAddress::parse(bad), std::invalid_argument) << "'" << bad << "'";
  }
}

TEST(ComponentPathParse, HostSlashNameOrNameAlone) {
  EXPECT_EQ(ComponentPath::parse("vm/sensor0"), (ComponentPath{"vm", "sensor0"}));
  EXPECT_EQ(ComponentPath::parse("sensor0"), (ComponentPath{"", "sensor0"}));
  EXPECT_EQ((ComponentPath{"vm", "sensor0"}).to_string(), "vm.host_cxt/sensor0.rtc");
  const auto name = (ComponentPath{"vm", "sensor0"}).to_name();
  ASSERT_EQ(name.length(), 2u);
  EXPECT_STREQ(name[0].id.in(), "vm");
  EXPECT_STREQ(name[0].kind.in(), "host_cxt");
  EXPECT_STREQ(name[1].id.in(), "sensor0");
  EXPECT_STREQ(name[1].kind.in(), "rtc");
  for (const char* bad : {"", "a/b/c", "/b", "a/"}) {
    EXPECT_THROW(ComponentPath::parse(bad), std::invalid_argument) << "'" << bad << "'";
  }
}

}  // namespace
