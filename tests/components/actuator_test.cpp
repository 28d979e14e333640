// SPDX-License-Identifier: Apache-2.0
// The Actuator without CORBA, against a recording arm: Fig. 7's limiter, the watchdog, NaN,
// zero velocity on off(), arm faults.
#include "components/actuator/actuator.h"

#include "component_test_support.h"
#include "rtm_test/recording_arm.h"

#include <gtest/gtest.h>

#include <limits>
#include <vector>

namespace {

using comp_test::cycle;
using comp_test::parameter;
using comp_test::statistic;
using comp_test::float6;

constexpr std::array<float, 6> kZero{};

using rtm_test::RecordingArm;

struct ActuatorUnderTest {
  RecordingArm* arm = nullptr;
  std::unique_ptr<rtm::comp::Actuator> actuator;
  std::uint64_t n = 0;
  explicit ActuatorUnderTest(rtm::comp::ActuatorParams params = {}) {
    auto fake = std::make_unique<RecordingArm>();
    arm = fake.get();
    actuator = std::make_unique<rtm::comp::Actuator>("actuator0", std::move(fake), params);
    actuator->on_start();
  }
  std::array<float, 6> step() {
    actuator->on_cycle(cycle(n++));
    return arm->ordered.back();
  }
  std::array<float, 6> step(std::array<float, 6> command) {
    actuator->command_in().deliver(float6(command));
    return step();
  }
};

TEST(ActuatorLimiter, EachComponentIsClampedToItsOwnLimit) {
  const RTM::TimedFloat6 cmd = float6({0.2f, -0.2f, 0.01f, 1.0f, -0.05f, -3.0f});
  const auto out = rtm::comp::clamp_twist({0.05f, 0.1f, 0.05f, 0.3f, 0.3f, 0.5f}, cmd.val);
  const std::array<float, 6> expected{0.05f, -0.1f, 0.01f, 0.3f, -0.05f, -0.5f};
  EXPECT_EQ(out, expected);
}

TEST(Actuator, CommandWithinLimitsReachesTheArmUnchanged) {
  ActuatorUnderTest t;
  const std::array<float, 6> cmd{0.01f, -0.02f, 0.03f, 0.1f, -0.1f, 0.2f};
  EXPECT_EQ(t.step(cmd), cmd);
  EXPECT_EQ(t.actuator->counters().clamped, 0u);
}

TEST(Actuator, CommandBeyondTheLimiterIsClampedAndCounted) {
  ActuatorUnderTest t;
  const std::array<float, 6> clamped{0.05f, -0.05f, 0, 0, 0, 0.3f};
  EXPECT_EQ(t.step({1, -1, 0, 0, 0, 9}), clamped);
  EXPECT_EQ(t.actuator->counters().clamped, 1u);
}

TEST(Actuator, NoCommandYetGivesZeroWithoutAWatchdogEvent) {
  ActuatorUnderTest t;
  for (int i = 0; i < 10; ++i) EXPECT_EQ(t.step(), kZero);
  EXPECT_EQ(t.actuator->counters().watchdog_events, 0u);
}

TEST(Actuator, WatchdogZeroesTheArmAfterThreePeriodsAndCountsOneEvent) {
  ActuatorUnderTest t;  // default watchdog: 3 periods
  const std::array<float, 6> cmd{0.01f, 0, 0, 0, 0, 0};
  EXPECT_EQ(t.step(cmd), cmd);
  EXPECT_EQ(t.step(), cmd) << "1 period without a command: the last one holds";
  EXPECT_EQ(t.step(), cmd) << "2 periods";
  EXPECT_FALSE(t.arm->braked.back());
  EXPECT_EQ(t.step(), kZero) << "3 periods: watchdog";
  EXPECT_TRUE(t.arm->braked.back()) << "the watchdog brakes (quick stop), not merely zero";
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(t.step(), kZero);
    EXPECT_TRUE(t.arm->braked.back()) << "held braked";
  }
  EXPECT_EQ(t.actuator->counters().watchdog_events, 1u) << "one event, not one per cycle";
  EXPECT_EQ(t.actuator->last_twist(), kZero);
  EXPECT_EQ(t.step(cmd), cmd) << "a new command ends the event";
  EXPECT_FALSE(t.arm->braked.back()) << "and releases the brake";
  for (int i = 0; i < 3; ++i) t.step();
  EXPECT_EQ(t.actuator->counters().watchdog_events, 2u);
}

TEST(Actuator, TheWatchdogsBrakeExpiresTheLastCommandSoAChainThroughItCountsNoAgeUntilTheNext) {
  ActuatorUnderTest t;
  const std::array<float, 6> cmd{0.01f, 0, 0, 0, 0, 0};
  t.step(cmd);
  EXPECT_FALSE(t.actuator->command_in().last_expired()) << "acting on it";
  t.step();
  t.step();
  EXPECT_FALSE(t.actuator->command_in().last_expired()) << "still repeated: still acted on";
  t.step();
  ASSERT_EQ(t.actuator->counters().watchdog_events, 1u);
  EXPECT_TRUE(t.actuator->command_in().last_expired()) << "braked: no longer acted on";
  t.step(cmd);
  EXPECT_FALSE(t.actuator->command_in().last_expired()) << "a new command is acted on";
}

TEST(Actuator, WatchdogPeriodsAreConfigurable) {
  rtm::comp::ActuatorParams p;
  p.watchdog_periods = 1;
  ActuatorUnderTest t(p);
  t.step({0.01f, 0, 0, 0, 0, 0});
  EXPECT_EQ(t.step(), kZero);
  EXPECT_EQ(t.actuator->counters().watchdog_events, 1u);
}

TEST(Actuator, NonFiniteCommandGivesZeroAndCountsOneEventPerEpisode) {
  ActuatorUnderTest t;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  t.step({0.01f, 0, 0, 0, 0, 0});
  EXPECT_EQ(t.step({nan, 0, 0, 0, 0, 0}), kZero);
  EXPECT_TRUE(t.arm->braked.back()) << "NaN brakes (quick stop)";
  EXPECT_EQ(t.step({0, 0, std::numeric_limits<float>::infinity(), 0, 0, 0}), kZero);
  EXPECT_EQ(t.step(), kZero) << "the bad command is not repeated";
  EXPECT_TRUE(t.arm->braked.back());
  EXPECT_EQ(t.actuator->counters().non_finite_events, 1u);
  t.step({0.01f, 0, 0, 0, 0, 0});
  t.step({nan, 0, 0, 0, 0, 0});
  EXPECT_EQ(t.actuator->counters().non_finite_events, 2u);
}

TEST(Actuator, OffCommandsZeroVelocity) {
  ActuatorUnderTest t;
  t.step({0.01f, 0, 0, 0, 0, 0});
  t.actuator->on_stop();
  EXPECT_EQ(t.arm->stops, 1);
  EXPECT_EQ(t.actuator->last_twist(), kZero);
}

TEST(Actuator, ArmFaultThrowsTheReasonAndOnAfterwardsResetsTheArm) {
  ActuatorUnderTest t;
  t.arm->status = rtm::comp::FaultKind::emergency;
  t.arm->reason = "emergency: drive 4 (E1): EMCY 0x5000 device hardware";
  t.actuator->command_in().deliver(float6({0.01f, 0, 0, 0, 0, 0}));
  try {
    t.actuator->on_cycle(cycle(0));
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("emergency: drive 4 (E1): EMCY 0x5000"), std::string::npos) << e.what();
  }
  t.actuator->on_start();
  EXPECT_EQ(t.arm->resets, 1);
}

TEST(Actuator, WatchdogArmsOnlyWithTheFirstCommandSoMembersTurnedOnLaterCountNoEvent) {
  ActuatorUnderTest t;
  for (int i = 0; i < 10; ++i) {
    EXPECT_EQ(t.step(), kZero);
    EXPECT_FALSE(t.arm->braked.back()) << "no command yet: zero velocity, no brake";
  }
  const std::array<float, 6> cmd{0, 0.01f, 0, 0, 0, 0};
  EXPECT_EQ(t.step(cmd), cmd);
  EXPECT_EQ(t.actuator->counters().watchdog_events, 0u);
}

TEST(Actuator, DriveCommandLossResetsTheArmCountsOnceAndMovesOnlyOnTheNextCommand) {
  ActuatorUnderTest t;
  const std::array<float, 6> cmd{0.01f, 0, 0, 0, 0, 0};
  t.step(cmd);
  t.arm->status = rtm::comp::FaultKind::command_loss;
  t.arm->reason = "command_loss: drive 4 (E1): EMCY 0x8250 RPDO timeout (command loss)";
  EXPECT_NO_THROW(t.step(cmd)) << "a communication fault is no component error";
  EXPECT_EQ(t.arm->resets, 1);
  EXPECT_EQ(t.actuator->counters().command_loss_recoveries, 1u);
  EXPECT_EQ(t.arm->status, rtm::comp::FaultKind::none) << "the fake's reset clears it";
  EXPECT_EQ(t.step(), kZero) << "the command from before the loss is not repeated";
  for (int i = 0; i < 5; ++i) EXPECT_EQ(t.step(), kZero);
  EXPECT_EQ(t.actuator->counters().watchdog_events, 0u) << "no watchdog until a command arrives again";
  EXPECT_EQ(t.step(cmd), cmd) << "moves again on the next command";
  EXPECT_EQ(t.actuator->counters().command_loss_recoveries, 1u);
}

TEST(Actuator, OtherArmFaultsStillPutTheComponentInError) {
  ActuatorUnderTest t;
  t.step({0.01f, 0, 0, 0, 0, 0});
  t.arm->status = rtm::comp::FaultKind::heartbeat_lost;
  t.arm->reason = "heartbeat_lost: drive 2 (S2): no heartbeat for 400 ms";
  EXPECT_THROW(t.step(), std::runtime_error);
  EXPECT_EQ(t.arm->resets, 0);
  EXPECT_EQ(t.actuator->counters().command_loss_recoveries, 0u);
}

// The bus master took its cycles back from the shared tick that runs this actuator (the tick
// sent no SYNC for several periods: a stall). The drives are held at zero; the tick takes the
// cycles again, and the actuator resumes as from a command loss, counted apart.
TEST(Actuator, CyclesTakenBackFromALateTickResetTheArmAndMoveOnlyOnTheNextCommand) {
  ActuatorUnderTest t;
  const std::array<float, 6> cmd{0, 0, 0.01f, 0, 0, 0};
  t.step(cmd);
  t.arm->status = rtm::comp::FaultKind::cycle_owner_lost;
  t.arm->reason = "cycle_owner_lost: the thread running the bus cycles sent no SYNC for 5 periods";
  EXPECT_NO_THROW(t.step(cmd)) << "a stall is no component error";
  EXPECT_EQ(t.arm->resets, 1);
  EXPECT_EQ(t.actuator->counters().cycle_owner_recoveries, 1u);
  EXPECT_EQ(t.actuator->counters().command_loss_recoveries, 0u) << "counted apart";
  EXPECT_EQ(t.step(), kZero) << "the command from before the stall is not repeated";
  EXPECT_EQ(t.step(cmd), cmd) << "moves again on the next command";
}

// A drive silent for a few SYNCs with its heartbeat on (the simulator's process stalled): reset
// and resume, a few times; gaps that keep coming within the window are a drive that answers no
// SYNC, an error. Gaps far apart each start a new window.
TEST(Actuator, FeedbackGapsAreResumedFromAFewTimesThenAnError) {
  using rtm::comp::Actuator;
  ActuatorUnderTest t;
  const std::array<float, 6> cmd{0, 0, 0.01f, 0, 0, 0};
  auto gap = [&] {
    t.arm->status = rtm::comp::FaultKind::missing_feedback;
    t.arm->reason = "missing_feedback: drive 1 (S1): no TPDO for 26 consecutive SYNCs";
    t.step(cmd);
  };
  t.step(cmd);
  for (std::uint32_t i = 1; i <= Actuator::kMaxFeedbackGaps; ++i) {
    EXPECT_NO_THROW(gap()) << "gap " << i;
    EXPECT_EQ(t.arm->resets, static_cast<int>(i));
    EXPECT_EQ(t.step(), kZero) << "the command from before the gap is not repeated";
    EXPECT_EQ(t.step(cmd), cmd) << "moves again on the next command";
  }
  EXPECT_EQ(t.actuator->counters().feedback_gap_recoveries, Actuator::kMaxFeedbackGaps);
  try {
    gap();
    FAIL() << "one gap more within the window is no stall";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("drive 1 (S1)"), std::string::npos) << e.what();
  }

  ActuatorUnderTest apart;
  for (std::uint32_t i = 0; i < 2 * Actuator::kMaxFeedbackGaps; ++i) {
    apart.arm->status = rtm::comp::FaultKind::missing_feedback;
    apart.arm->reason = "missing_feedback: drive 2 (S2): no TPDO for 26 consecutive SYNCs";
    EXPECT_NO_THROW(apart.step(cmd)) << "gap " << i;
    for (std::uint64_t c = 0; c <= Actuator::kFeedbackGapWindowCycles; ++c) apart.step();
  }
  EXPECT_EQ(apart.actuator->counters().feedback_gap_recoveries, 2 * Actuator::kMaxFeedbackGaps);
}

TEST(Actuator, EveryOtherLatchedFaultIsAComponentError) {
  using rtm::comp::FaultKind;
  for (const FaultKind kind :
       {FaultKind::drive_fault, FaultKind::drive_disabled, FaultKind::emergency, FaultKind::heartbeat_lost,
        FaultKind::bus_error, FaultKind::node_not_operational, FaultKind::ik_failed}) {
    ActuatorUnderTest t;
    t.step({0.01f, 0, 0, 0, 0, 0});
    t.arm->status = kind;
    t.arm->reason = std::string(to_string(kind)) + ": test";
    EXPECT_THROW(t.step(), std::runtime_error) << to_string(kind);
    EXPECT_EQ(t.arm->resets, 0) << to_string(kind);
    EXPECT_EQ(t.actuator->counters().command_loss_recoveries, 0u) << to_string(kind);
    EXPECT_EQ(t.actuator->counters().not_ready_cycles, 0u) << to_string(kind);
  }
}

TEST(Actuator, ArmNotYetEnabledIsCountedNotAnError) {
  ActuatorUnderTest t;
  t.arm->status = rtm::comp::FaultKind::not_enabled;
  EXPECT_NO_THROW(t.step({0.01f, 0, 0, 0, 0, 0}));
  EXPECT_EQ(t.actuator->counters().not_ready_cycles, 1u);
  EXPECT_EQ(t.actuator->last_twist(), kZero);
}

TEST(Actuator, NegativeLimitOrZeroWatchdogIsRefused) {
  rtm::comp::ActuatorParams p;
  p.limit[2] = -0.1f;
  EXPECT_THROW(rtm::comp::Actuator("a", std::make_unique<RecordingArm>(), p), std::invalid_argument);
  rtm::comp::ActuatorParams q;
  q.watchdog_periods = 0;
  EXPECT_THROW(rtm::comp::Actuator("a", std::make_unique<RecordingArm>(), q), std::invalid_argument);
}

TEST(ActuatorLatency, SampleToDriveIsTheBusSendTimeOfThatCommandMinusItsStamp) {
  ActuatorUnderTest t;
  const std::int64_t stamp_ns = 1'700'000'000'000'000'000;
  t.actuator->command_in().deliver(float6({0.01f, 0, 0, 0, 0, 0}, stamp_ns));
  t.step();
  const std::uint64_t handed = t.arm->sequence;
  ASSERT_GT(handed, 0u);
  EXPECT_EQ(t.actuator->latency().latency_samples, 0u) << "not sent yet: nothing to record";
  EXPECT_GT(t.actuator->latency().handover_max_ns, 0) << "the hand-over is recorded at once";

  t.arm->sent = {handed - 1, stamp_ns + 100'000};  // an older command left: not this one
  t.step();
  EXPECT_EQ(t.actuator->latency().latency_samples, 0u);

  t.arm->sent = {handed, stamp_ns + 450'000};  // this command's RPDOs were written 450 us on
  t.step();
  const rtm::comp::ActuatorLatency c = t.actuator->latency();
  EXPECT_EQ(c.latency_samples, 1u);
  EXPECT_EQ(c.latency_max_ns, 450'000);
  EXPECT_EQ(c.latency_p99_ns, 450'000);
  t.step();
  EXPECT_EQ(t.actuator->latency().latency_samples, 1u) << "each command is recorded once";
}

TEST(ActuatorLatency, ACommandOvertakenByALaterOneStillCountsWhenTheLaterLeaves) {
  ActuatorUnderTest t;
  const std::int64_t stamp_ns = 1'700'000'000'000'000'000;
  t.actuator->command_in().deliver(float6({0.01f, 0, 0, 0, 0, 0}, stamp_ns));
  t.step();
  t.actuator->command_in().deliver(float6({0.02f, 0, 0, 0, 0, 0}, stamp_ns + 2'000'000));
  t.step();
  t.arm->sent = {t.arm->sequence, stamp_ns + 2'300'000};
  t.step();
  const rtm::comp::ActuatorLatency c = t.actuator->latency();
  EXPECT_EQ(c.latency_samples, 1u) << "only the newest command is followed";
  EXPECT_EQ(c.latency_max_ns, 300'000) << "measured from the newest command's stamp";
}

TEST(ActuatorLatency, AnArmThatCannotTellRecordsNoBusLatency) {
  ActuatorUnderTest t;
  t.arm->status = rtm::comp::FaultKind::not_enabled;  // no sequence handed out
  t.step({0.01f, 0, 0, 0, 0, 0});
  t.arm->sent = {5, 1};
  t.step();
  EXPECT_EQ(t.actuator->latency().latency_samples, 0u);
}

// ---------------------------------------------------------------- the measured pose

std::array<float, 6> as_floats(const std::array<double, 6>& v) {
  std::array<float, 6> out{};
  for (std::size_t i = 0; i < 6; ++i) out[i] = static_cast<float>(v[i]);
  return out;
}

TEST(ActuatorPose, ThePortIsOutPort0PoseWithPositionAndRotationVectorInMAndRad) {
  ActuatorUnderTest t;
  ASSERT_EQ(t.actuator->out_ports().size(), 1u);
  const rtm::OutPortBase& port = *t.actuator->out_ports()[0];
  EXPECT_EQ(port.port_name(), "pose");
  EXPECT_EQ(port.full_name(), "actuator0.pose");
  const std::vector<std::string> names{"x", "y", "z", "rx", "ry", "rz"}, units{"m", "m", "m", "rad", "rad", "rad"};
  ASSERT_EQ(port.info().elements.size(), 6u);
  for (std::size_t i = 0; i < 6; ++i) {
    EXPECT_EQ(port.info().elements[i].name, names[i]);
    EXPECT_EQ(port.info().elements[i].unit, units[i]);
  }
  ASSERT_EQ(t.actuator->in_ports().size(), 1u) << "the pose is an OutPort beside the one InPort";
}

TEST(ActuatorPose, EachCycleAfterTheOrderThePoseTheArmMeasuresIsWrittenStampedNowNotWithTheCommandsStamp) {
  ActuatorUnderTest t;
  const std::array<double, 6> measured{0.45, -0.125, 0.9, 0.25, -1.5, 3.0};
  t.arm->pose = measured;
  const std::int64_t command_stamp_ns = rtm::to_ns(rtm::now()) - 5'000'000'000;  // a command 5 s old
  t.actuator->command_in().deliver(float6({0.01f, 0, 0, 0, 0, 0}, command_stamp_ns));
  const std::int64_t before_ns = rtm::to_ns(rtm::now());
  t.step();
  const std::int64_t after_ns = rtm::to_ns(rtm::now());
  RTM::TimedFloat6 pose{};
  ASSERT_TRUE(t.actuator->pose_out().latest(pose)) << "no pose written";
  EXPECT_EQ(comp_test::values(pose), as_floats(measured));
  EXPECT_GE(rtm::to_ns(pose.tm), before_ns) << "stamped when measured, not " << command_stamp_ns;
  EXPECT_LE(rtm::to_ns(pose.tm), after_ns);
  EXPECT_EQ(t.arm->pose_reads, 1);
  EXPECT_EQ(t.arm->orders_before_pose_read, 1u) << "read after the command was handed to the arm";
  EXPECT_EQ(t.actuator->pose_out().counters_snapshot().written, 1u);
}

TEST(ActuatorPose, ThePoseIsWrittenOnCyclesWithoutACommandAndOnCyclesThatBrake) {
  ActuatorUnderTest t;
  t.arm->pose = std::array<double, 6>{0.1, 0.2, 0.3, 0, 0, 0};
  t.step();  // no command yet: zero velocity
  EXPECT_EQ(t.actuator->pose_out().counters_snapshot().written, 1u);
  t.step({0.01f, 0, 0, 0, 0, 0});
  for (int i = 0; i < 3; ++i) t.step();  // the watchdog fires: quick stop
  ASSERT_TRUE(t.arm->braked.back());
  ASSERT_EQ(t.actuator->counters().watchdog_events, 1u);
  t.arm->pose = std::array<double, 6>{0.1, 0.2, 0.25, 0, 0, 0};
  t.step();  // braked
  ASSERT_TRUE(t.arm->braked.back());
  EXPECT_EQ(t.actuator->pose_out().counters_snapshot().written, 6u) << "one pose per cycle";
  RTM::TimedFloat6 pose{};
  ASSERT_TRUE(t.actuator->pose_out().latest(pose));
  EXPECT_EQ(pose.val[2], 0.25f) << "the pose of the braked cycle";
  t.arm->status = rtm::comp::FaultKind::not_enabled;  // drives not enabled: zero, yet measured
  t.step({0.01f, 0, 0, 0, 0, 0});
  EXPECT_EQ(t.actuator->pose_out().counters_snapshot().written, 7u);
}

TEST(ActuatorPose, NothingIsWrittenWhileTheArmCannotTellItsPose) {
  ActuatorUnderTest t;  // the fake answers no pose until one is set
  for (int i = 0; i < 3; ++i) t.step({0.01f, 0, 0, 0, 0, 0});
  EXPECT_EQ(t.arm->pose_reads, 3) << "asked every cycle";
  EXPECT_EQ(t.actuator->pose_out().counters_snapshot().written, 0u);
  RTM::TimedFloat6 pose{};
  EXPECT_FALSE(t.actuator->pose_out().latest(pose));
  t.arm->pose = std::array<double, 6>{};
  t.step();
  EXPECT_EQ(t.actuator->pose_out().counters_snapshot().written, 1u) << "from the first cycle it can";
}

TEST(ActuatorPose, AnArmWithoutPoseFeedbackSaysItCannotTell) {
  // The seam's default: an arm that does not override measured_tool_pose.
  class Blind final : public rtm::pa10::VelocityArm {
   public:
    Blind() : VelocityArm(diagnostics_) {}
    rtm::pa10::FaultKind order_velocity(const std::array<float, 6>&) override { return rtm::pa10::FaultKind::none; }
    rtm::pa10::FaultKind quick_stop() override { return rtm::pa10::FaultKind::none; }
    void stop() override {}
    rtm::pa10::ArmFault fault() const override { return {}; }
    void reset() override {}

   private:
    rtm::pa10::ArmDiagnostics diagnostics_;
  };
  Blind blind;
  std::array<double, 6> pose{1, 2, 3, 4, 5, 6};
  EXPECT_FALSE(blind.measured_tool_pose(pose));
  EXPECT_EQ(pose, (std::array<double, 6>{1, 2, 3, 4, 5, 6})) << "left untouched";
}

TEST(LatencyHistogram, BucketsAre1usBelow1ms100usTo10msThen1ms) {
  using H = rtm::LatencyHistogram;
  EXPECT_EQ(H::upper_edge_ns(H::bucket_of(0)), 1'000);
  EXPECT_EQ(H::upper_edge_ns(H::bucket_of(999'999)), 1'000'000);
  EXPECT_EQ(H::upper_edge_ns(H::bucket_of(1'000'000)), 1'100'000);
  EXPECT_EQ(H::upper_edge_ns(H::bucket_of(4'020'000)), 4'100'000);
  EXPECT_EQ(H::upper_edge_ns(H::bucket_of(9'999'999)), 10'000'000);
  EXPECT_EQ(H::upper_edge_ns(H::bucket_of(10'000'000)), 11'000'000);
  EXPECT_EQ(H::upper_edge_ns(H::bucket_of(5'000'000'000)), -1);
  EXPECT_EQ(H::bucket_of(-5), H::bucket_of(0));
}

TEST(LatencyHistogram, PercentilesAreBucketEdgesCappedAtTheMaximum) {
  rtm::LatencyHistogram h;
  EXPECT_EQ(h.percentile_ns(0.5), 0);
  for (int i = 0; i < 98; ++i) h.record(1'234'000);  // 1.234 ms
  h.record(2'950'000);
  h.record(7'000'000);
  EXPECT_EQ(h.count(), 100u);
  EXPECT_EQ(h.percentile_ns(0.5), 1'300'000);
  EXPECT_EQ(h.percentile_ns(0.99), 3'000'000);
  EXPECT_EQ(h.percentile_ns(1.0), 7'000'000) << "capped at the largest value recorded";
  EXPECT_EQ(h.max_ns(), 7'000'000);
}

TEST(Actuator, ALimitSetWhileRunningClampsTheNextCommand) {
  ActuatorUnderTest t;
  EXPECT_EQ(t.step({0.04f, 0, 0, 0, 0, 0}), (std::array<float, 6>{0.04f, 0, 0, 0, 0, 0}));
  parameter(*t.actuator, "limit").set("0.01 0.01 0.01 0.1 0.1 0.1");
  EXPECT_EQ(t.step({0.04f, 0, 0, 0, 0, 0}), (std::array<float, 6>{0.01f, 0, 0, 0, 0, 0}));
  EXPECT_EQ(statistic(*t.actuator, "clamped"), 1.0);
  EXPECT_THROW(parameter(*t.actuator, "limit").set("0.01 0.01 0.01 0.1 0.1 -0.1"), std::invalid_argument);
  EXPECT_EQ(t.actuator->params().limit[5], 0.1f) << "a refused value changes nothing";
}

TEST(Actuator, WatchdogPeriodsSetWhileOffTakeEffectAtTheNextOn) {
  ActuatorUnderTest t;  // 3 periods
  parameter(*t.actuator, "watchdog_periods").set("1");
  EXPECT_EQ(parameter(*t.actuator, "watchdog_periods").access, rtm::ParameterAccess::when_off);
  t.actuator->on_start();
  t.step({0.01f, 0, 0, 0, 0, 0});
  EXPECT_EQ(t.step(), kZero);
  EXPECT_EQ(statistic(*t.actuator, "watchdog_events"), 1.0);
  EXPECT_EQ(t.actuator->in_ports()[0]->port_name(), "twist");
}

}  // namespace
