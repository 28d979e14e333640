// SPDX-License-Identifier: Apache-2.0
// Re-simulation of the controller (host/cycle_log.h): a run logged with its cycles, then the
// controller's logic built afresh and stepped through the log on logical time. Unchanged, every
// output is the logged one byte for byte; with another gain, each output differs by what the
// new gain makes of the logged inputs.
#include "components/controller/controller.h"

#include "component_test_support.h"
#include "host/cycle_log.h"
#include "mcap/reader.h"
#include "mcap/writer.h"
#include "rtm/cdr.h"
#include "rtm_test/allocation_counter.h"
#include "rtm_test/orb_environment.h"
#include "rtm_test/temp_dir.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cmath>
#include <filesystem>
#include <limits>

namespace {

using comp_test::float6;
using rtm::comp::Controller;
using rtm::comp::ControllerParams;

const auto* const kOrb = ::testing::AddGlobalTestEnvironment(new rtm_test::OrbEnvironment);

constexpr std::int64_t kPeriod = 2'000'000;
constexpr std::uint64_t kCycles = 600;

ControllerParams params() {
  ControllerParams p;
  p.gain = {0.002f, 0.002f, 0.003f, 0.01f, 0.01f, 0.01f};
  p.approach_speed_m_s = 0;  // the paper's P, contact or not: gain applies to every command
  return p;
}

std::unique_ptr<Controller> controller(const std::string& name = "controller0") {
  return std::make_unique<Controller>(name, params());
}

// The sensor's wrench and the reference given before cycle k (nullopt: none that cycle).
std::optional<std::array<float, 6>> wrench_at(std::uint64_t k) {
  if (k >= 200 && k < 210) return std::nullopt;  // a gap: the input goes stale, commands are withheld
  const float t = static_cast<float>(k) * 0.002f;
  std::array<float, 6> w{3.0f * std::sin(7 * t), -2.0f + std::cos(3 * t), -10.0f + 0.5f * t, 0.1f, -0.2f, 0.05f * t};
  if (k == 300) w[2] = std::numeric_limits<float>::quiet_NaN();  // a bad datum: withheld too
  return w;
}
std::optional<std::array<float, 6>> reference_at(std::uint64_t k) {
  if (k % 3 != 0) return std::nullopt;  // the reference comes every third cycle
  return std::array<float, 6>{0, 0, 10.0f + static_cast<float>(k % 50) * 0.1f, 0, 0, 0};
}

rtm::CycleContext context(std::uint64_t k) {
  rtm::CycleContext ctx;
  ctx.cycle = k;
  ctx.period_ns = kPeriod;
  ctx.deadline_ns = 1'000'000'000 + static_cast<std::int64_t>(k) * kPeriod;
  ctx.wake_ns = ctx.deadline_ns + 30'000 + static_cast<std::int64_t>(k % 7) * 1'000;
  return ctx;
}

class ControllerReplay : public ::testing::Test {
 protected:
  // Runs the controller for kCycles with its cycles logged into `log`; returns its commands count.
  std::uint64_t run_logged(const std::string& log) {
    rtm::ComponentServant servant(controller(), rtm::ExternalTick{});
    auto& c = static_cast<Controller&>(servant.component());
    std::uint64_t commands = 0;
    {
      rtm::CycleLog cycle_log(servant, log);
      servant.on();
      const rtm::CycleFunction step = servant.cycle_function();
      for (std::uint64_t k = 0; k < kCycles; ++k) {
        const std::int64_t stamp = 5'000'000'000 + static_cast<std::int64_t>(k) * kPeriod;
        if (const auto w = wrench_at(k)) c.sensor_in().deliver(float6(*w, stamp));
        if (const auto r = reference_at(k)) c.reference_in().deliver(float6(*r, stamp));
        EXPECT_TRUE(step(context(k)));
      }
      servant.off();
      commands = c.counters().commands;
      EXPECT_EQ(cycle_log.lost(), 0u);
    }
    return commands;
  }

  rtm_test::TempDir dir_{"rtm-replay"};
};

TEST_F(ControllerReplay, UnchangedItsOutputsAreTheLoggedOnesByteForByte) {
  const std::string log = dir_.file("controller.mcap");
  const std::uint64_t commands = run_logged(log);
  ASSERT_GT(commands, 500u);
  ASSERT_LT(commands, kCycles) << "the gap and the NaN withhold some commands";
  struct stat st {};
  ASSERT_EQ(::stat(log.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u) << "a log holds the run's data: its owner's alone";

  rtm::ReplayOptions options;
  options.output = dir_.file("replayed.mcap");
  const rtm::ReplayResult r = rtm::replay_cycle_log(controller(), log, options);
  EXPECT_EQ(r.component, "controller0");
  EXPECT_EQ(r.cycles, kCycles);
  EXPECT_EQ(r.writes, commands);
  EXPECT_EQ(r.differing, 0u);
  EXPECT_EQ(r.unjudged, 0u);
  EXPECT_EQ(r.unanswered_reads, 0u);
  EXPECT_EQ(r.unused_answers, 0u);
  EXPECT_EQ(r.logged_span_ns, static_cast<std::int64_t>(kCycles - 1) * kPeriod);
  EXPECT_TRUE(r.warnings.empty());

  // The replayed outputs' file holds the logged commands, in order.
  const rtm::mcap::Reader logged(log), replayed(options.output);
  const auto* logged_channel = logged.channel(std::string("controller0.twist"));
  const auto* replayed_channel = replayed.channel(std::string("controller0.twist"));
  ASSERT_NE(logged_channel, nullptr);
  ASSERT_NE(replayed_channel, nullptr);
  std::vector<std::vector<std::uint8_t>> a, b;
  for (const auto& m : logged.messages())
    if (m.channel_id == logged_channel->id) a.push_back(m.data);
  for (const auto& m : replayed.messages())
    if (m.channel_id == replayed_channel->id) b.push_back(m.data);
  EXPECT_EQ(a.size(), commands);
  EXPECT_EQ(a, b);
}

TEST_F(ControllerReplay, AnotherGainShowsInEveryCommandByWhatItMakesOfTheLoggedInputs) {
  const std::string log = dir_.file("controller.mcap");
  const std::uint64_t commands = run_logged(log);
  rtm::ReplayOptions options;
  options.parameters["gain"] = "0.004 0.002 0.003 0.01 0.01 0.01";  // vx's gain doubled
  const rtm::ReplayResult r = rtm::replay_cycle_log(controller(), log, options);
  EXPECT_EQ(r.writes, commands);
  ASSERT_EQ(r.mismatches.size(), r.differing);
  ASSERT_GT(r.differing, 0u);
  // A command differs where its vx was not 0: by as much again as it was.
  std::uint64_t nonzero_vx = 0;
  for (const auto& m : r.mismatches) {
    ASSERT_FALSE(m.logged.empty());
    ASSERT_FALSE(m.replayed.empty());
    const RTM::TimedFloat6* was = nullptr;
    const RTM::TimedFloat6* now = nullptr;
    const CORBA::Any a = rtm::from_cdr(RTM::_tc_TimedFloat6, m.logged);
    const CORBA::Any b = rtm::from_cdr(RTM::_tc_TimedFloat6, m.replayed);
    ASSERT_TRUE(a >>= was);
    ASSERT_TRUE(b >>= now);
    EXPECT_FLOAT_EQ(now->val[0], 2 * was->val[0]) << "cycle " << m.cycle;
    for (int i = 1; i < 6; ++i) EXPECT_EQ(now->val[i], was->val[i]) << "cycle " << m.cycle << " element " << i;
    EXPECT_EQ(now->tm.sec, was->tm.sec);
    EXPECT_EQ(now->tm.nsec, was->tm.nsec);
    nonzero_vx += was->val[0] != 0 ? 1 : 0;
  }
  EXPECT_EQ(r.differing, nonzero_vx) << "only commands whose vx was not 0 differ";
  EXPECT_EQ(r.mismatches.front().group, "cycle");
}

TEST_F(ControllerReplay, ALogIsReplayedOnlyByTheComponentItCameFrom) {
  const std::string log = dir_.file("controller.mcap");
  run_logged(log);
  EXPECT_THROW(rtm::replay_cycle_log(controller("controller1"), log), std::runtime_error);
  rtm::ReplayOptions options;
  options.parameters["no_such"] = "1";
  EXPECT_THROW(rtm::replay_cycle_log(controller(), log, options), std::runtime_error);
  options.parameters = {{"gain", "1 2"}};  // not six numbers
  EXPECT_THROW(rtm::replay_cycle_log(controller(), log, options), std::runtime_error);
}

TEST_F(ControllerReplay, ALogCutShortOrNotALogIsRefusedWithTheReason) {
  const std::string log = dir_.file("controller.mcap");
  run_logged(log);
  const auto size = std::filesystem::file_size(log);
  std::filesystem::resize_file(log, size / 2);
  EXPECT_THROW(rtm::read_cycle_log_info(log), std::exception);
  EXPECT_THROW(rtm::replay_cycle_log(controller(), log), std::exception);
  const std::string other = dir_.file("other.mcap");
  {
    rtm::mcap::Writer w(other);
    w.close();
  }
  try {
    rtm::read_cycle_log_info(other);
    ADD_FAILURE() << "an MCAP file with no cycle-log metadata was taken";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("not a cycle log"), std::string::npos) << e.what();
  }
}

// Logging takes nothing from the cycle but a copy: no allocation on the cycle's thread, once
// running (the controller's own warnings aside: its inputs stay fresh here).
TEST_F(ControllerReplay, ALoggedCycleAllocatesNothing) {
  rtm::ComponentServant servant(controller(), rtm::ExternalTick{});
  auto& c = static_cast<Controller&>(servant.component());
  rtm::CycleLog cycle_log(servant, dir_.file("controller.mcap"));
  servant.on();
  const rtm::CycleFunction step = servant.cycle_function();
  std::uint64_t allocations = 0;
  for (std::uint64_t k = 0; k < 400; ++k) {
    const auto w = float6({1, 2, -9, 0, 0, 0}, 5'000'000'000 + static_cast<std::int64_t>(k) * kPeriod);
    c.sensor_in().deliver(w);
    c.reference_in().deliver(float6({0, 0, 10, 0, 0, 0}, w.tm.sec * 1'000'000'000LL + w.tm.nsec));
    const std::uint64_t before = rtm_test::allocations_on_this_thread();
    ASSERT_TRUE(step(context(k)));
    if (k >= 10) allocations += rtm_test::allocations_on_this_thread() - before;
  }
  servant.off();
  EXPECT_EQ(c.counters().commands, 400u);
  EXPECT_EQ(allocations, 0u) << "allocations in 390 logged cycles";
  EXPECT_EQ(cycle_log.lost(), 0u);
}

// A component that writes more in one cycle than the log keeps slots for: what the log could not
// keep is counted and its cycle is not judged, never compared as if it were whole.
class Burst final : public rtm::Component {
 public:
  Burst() : Component("burst0", "burst") {}
  void on_cycle(const rtm::CycleContext& ctx) override {
    const std::size_t n = ctx.cycle == 1 ? 3000 : 2;
    for (std::size_t i = 0; i < n; ++i) out.write(float6({static_cast<float>(i), 0, 0, 0, 0, 0}, ctx.deadline_ns));
  }
  rtm::OutPort<RTM::TimedFloat6>& out = add_out_port<RTM::TimedFloat6>("out0");
};

TEST_F(ControllerReplay, WhatTheLogCouldNotKeepIsCountedAndItsCycleNotJudged) {
  const std::string log = dir_.file("burst.mcap");
  {
    rtm::ComponentServant servant(std::make_unique<Burst>(), rtm::ExternalTick{});
    rtm::CycleLogOptions options;
    options.write_every = std::chrono::hours(1);  // written out by flush() alone: after each cycle
    rtm::CycleLog cycle_log(servant, log, options);
    servant.on();
    const rtm::CycleFunction step = servant.cycle_function();
    for (std::uint64_t k = 0; k < 4; ++k) {
      step(context(k));
      cycle_log.flush();
    }
    servant.off();
    EXPECT_EQ(cycle_log.lost(), 3000u - options.slots_per_port);
  }
  const rtm::CycleLogInfo info = rtm::read_cycle_log_info(log);
  EXPECT_EQ(info.lost, 3000u - rtm::CycleLogOptions{}.slots_per_port);
  const rtm::ReplayResult r = rtm::replay_cycle_log(std::make_unique<Burst>(), log);
  EXPECT_EQ(r.cycles, 4u);
  EXPECT_EQ(r.unjudged, 1u);
  EXPECT_EQ(r.differing, 0u);
  EXPECT_EQ(r.writes, 6u) << "the three whole cycles' writes";
  EXPECT_FALSE(r.warnings.empty());
}

}  // namespace
