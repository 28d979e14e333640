// SPDX-License-Identifier: Apache-2.0
// Pa10Master against the PA10's CAN nodes as pa10-sim emulates them (on a kinematic plant, in
// lock-step) on the user-space bus: startup, lock-step PDO exchange, faults with reasons and
// zero command, fault reset, heartbeat loss, counted bad frames, the periodic thread, a
// separate sensor bus, and the passive sensor listener.
#include "arm/can/master.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <time.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <set>
#include <string_view>
#include <thread>
#include <vector>

#include "arm/can/local_bus.h"
#include "arm/can/sensor_listener.h"
#include "arm/can/supervisor.h"
#include "rtm_test/allocation_counter.h"
#include "rtm_test/eventually.h"
#include "rtm_test/manual_clock.h"
#include "rtm_test/can/lock_step.h"
#include "rtm_test/can/master_rig.h"

namespace rtm::can {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;
using rtm_test::eventually;
using testing::delivered;
using testing::EmulatedPa10;
using testing::Rig;
using testing::all_seen_and_delivered;
using testing::kLockStepBound_ns;
using testing::seen_and_delivered;
using testing::sync_answers;
using testing::TempDir;
using testing::test_config;

template <class Predicate>
bool step_until(Pa10Master& m, Predicate p, int max_steps = 2000) {
  for (int i = 0; i < max_steps; ++i) {
    if (p()) return true;
    m.step();
  }
  return p();
}

TEST(FaultKind, EachKindHasItsOwnNameAndOnlyNoneAndNotEnabledAreNotLatched) {
  EXPECT_EQ(to_string(FaultKind::none), "none");
  EXPECT_EQ(to_string(FaultKind::not_enabled), "not_enabled");
  EXPECT_EQ(to_string(FaultKind::command_loss), "command_loss");
  EXPECT_EQ(to_string(FaultKind::drive_fault), "drive_fault");
  EXPECT_EQ(to_string(FaultKind::ik_failed), "ik_failed");
  std::set<std::string_view> names;
  for (int k = 0; k <= static_cast<int>(FaultKind::ik_failed); ++k) {
    const auto kind = static_cast<FaultKind>(k);
    EXPECT_TRUE(names.insert(to_string(kind)).second) << to_string(kind);
    EXPECT_EQ(latched(kind), kind != FaultKind::none && kind != FaultKind::not_enabled) << to_string(kind);
  }
}

TEST(FaultKind, OnlyCommunicationFaultsAndASilentForceSensorAreForTheLayerAboveToRecoverFrom) {
  EXPECT_EQ(recovery(FaultKind::none, 0), Recovery::none);
  EXPECT_EQ(recovery(FaultKind::not_enabled, 0), Recovery::none);
  EXPECT_EQ(recovery(FaultKind::command_loss, drive_node(3)), Recovery::reset);
  EXPECT_EQ(recovery(FaultKind::cycle_owner_lost, 0), Recovery::reset);
  EXPECT_EQ(recovery(FaultKind::missing_feedback, drive_node(0)), Recovery::reset_a_few);
  EXPECT_EQ(recovery(FaultKind::heartbeat_lost, kWristSensorNode), Recovery::wait_for_node);
  EXPECT_EQ(recovery(FaultKind::heartbeat_lost, kJoystickSensorNode), Recovery::wait_for_node);
  EXPECT_EQ(recovery(FaultKind::heartbeat_lost, drive_node(1)), Recovery::stop) << "a silent drive is no sensor";
  EXPECT_EQ(recovery(FaultKind::heartbeat_lost, 0), Recovery::stop) << "a node the arm cannot name";
  for (FaultKind kind : {FaultKind::drive_fault, FaultKind::drive_disabled, FaultKind::emergency, FaultKind::bus_error,
                         FaultKind::node_not_operational, FaultKind::foreign_master, FaultKind::spoofed_frame,
                         FaultKind::following_error, FaultKind::ik_failed})
    EXPECT_EQ(recovery(kind, kWristSensorNode), Recovery::stop) << to_string(kind);
}

TEST(Pa10Master, StartupSetsCyclicSyncVelocityModeAndEnablesEveryDrive) {
  Rig rig;
  rig.master->start();
  EXPECT_TRUE(rig.master->enabled());
  EXPECT_FALSE(rig.master->fault().active());
  for (std::uint8_t node : {kWristSensorNode, kJoystickSensorNode})
    EXPECT_EQ(rig.nodes->nmt_state(node), NmtState::operational) << int{node};
  for (int j = 0; j < kDriveCount; ++j) {
    EXPECT_EQ(rig.nodes->nmt_state(drive_node(j)), NmtState::operational) << joint_name(j);
    EXPECT_EQ(rig.nodes->mode_of_operation(drive_node(j)), 9) << joint_name(j);
    EXPECT_EQ(rig.nodes->drive_state(drive_node(j)), DriveState::operation_enabled) << joint_name(j);
  }
  const JointState s = rig.master->joint_state();
  EXPECT_TRUE(s.complete);
  for (auto sw : s.statusword) EXPECT_EQ(sw & statusword::kStateMask, statusword::kOperationEnabled);
}

// A master restarted right after the last one stopped finds a drive that timed out meanwhile
// (EMCY 0x8250, drive in fault): that EMCY belongs to the previous session, and start-up's
// enable sequence resets the fault.
TEST(Pa10Master, AnEmcyFromBeforeStartUpIsNoFaultAndTheEnableSequenceResetsTheDrive) {
  Rig rig;
  auto probe = open_bus(rig.spec);
  ASSERT_TRUE(eventually([&] { return rig.hub.endpoint_count() == 3; }));  // master, nodes, probe
  rig.nodes->inject_fault(drive_node(3), emcy::kRpdoTimeout);
  ASSERT_TRUE(seen_and_delivered(*probe, cob::kEmcyBase + drive_node(3)));  // the EMCY waits in the master's socket
  ASSERT_NO_THROW(rig.master->start());
  EXPECT_TRUE(rig.master->enabled()) << rig.master->fault().reason;
  EXPECT_FALSE(rig.master->fault().active()) << rig.master->fault().reason;
  EXPECT_EQ(rig.nodes->drive_state(drive_node(3)), DriveState::operation_enabled);
  EXPECT_GE(rig.master->counters().emcy_frames, 1u) << "seen and counted";
}

TEST(Pa10Master, StartupTimeoutNamesEveryMissingNode) {
  EmulatedPa10::Options options;
  options.disconnected = {3, kJoystickSensorNode};
  MasterConfig config = test_config();
  config.boot_timeout_ns = 1'000'000'000;  // long enough for the live nodes on a loaded machine
  Rig rig(options, config);
  try {
    rig.master->start();
    FAIL() << "expected start() to fail";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("no boot-up or heartbeat"));
    EXPECT_THAT(e.what(), HasSubstr("drive 3 (S3)"));
    EXPECT_THAT(e.what(), HasSubstr("joystick sensor 0x11"));
    EXPECT_THAT(e.what(), ::testing::Not(HasSubstr("drive 2 ")));
    EXPECT_THAT(e.what(), HasSubstr(rig.spec));
  }
}

TEST(Pa10Master, StartupReportsAnSdoAbortWithNodeObjectAndCode) {
  EmulatedPa10::Options options;
  options.rig.drive.offers_csv_mode = false;  // a firmware without cyclic synchronous velocity
  Rig rig(options);
  try {
    rig.master->start();
    FAIL() << "expected start() to fail";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("drive 1 (S1) aborted the SDO"));
    EXPECT_THAT(e.what(), HasSubstr("0x6060:00"));
    EXPECT_THAT(e.what(), HasSubstr("0x06090030"));
  }
}

// A thread that set a target and then hung must not leave the arm moving: the target expires
// after target_expiry_periods cycles, zero goes out, and the next target moves the arm again.
TEST(Pa10Master, ATargetNotRenewedForTheExpiryPeriodsBecomesZeroAndTheNextTargetMovesAgain) {
  MasterConfig config = test_config();
  config.target_expiry_periods = 5;
  Rig rig({}, config);
  rig.master->start();
  const std::array<double, kDriveCount> target = {0.1, -0.2, 0.3, -0.4, 0.5, -0.6, 0.7};
  rig.master->set_target_velocities(target);
  for (int i = 0; i < 4; ++i) ASSERT_TRUE(rig.master->step()) << "step " << i;
  EXPECT_DOUBLE_EQ(rig.nodes->latched_velocity_rad_s(drive_node(0)), target[0]) << "still fresh";
  EXPECT_EQ(rig.master->counters().target_expiries, 0u);
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(rig.master->step()) << "step " << i;
  for (int j = 0; j < kDriveCount; ++j)
    EXPECT_EQ(rig.nodes->latched_velocity_rad_s(drive_node(j)), 0.0) << joint_name(j) << ": expired";
  EXPECT_EQ(rig.master->counters().target_expiries, 1u);
  EXPECT_FALSE(rig.master->fault().active()) << "an expiry stops the arm, it is no fault";
  rig.master->set_target_velocities(target);
  ASSERT_TRUE(rig.master->step());
  EXPECT_DOUBLE_EQ(rig.nodes->latched_velocity_rad_s(drive_node(6)), target[6]) << "moves again";
  EXPECT_EQ(rig.master->counters().target_expiries, 1u);
}

// Renewing the target every cycle, even with the same values, never expires it.
TEST(Pa10Master, ATargetRenewedEveryCycleNeverExpires) {
  MasterConfig config = test_config();
  config.target_expiry_periods = 2;
  Rig rig({}, config);
  rig.master->start();
  const std::array<double, kDriveCount> target = {0.2, 0, 0, 0, 0, 0, 0};
  for (int i = 0; i < 20; ++i) {
    rig.master->set_target_velocities(target);
    ASSERT_TRUE(rig.master->step()) << "step " << i;
    ASSERT_DOUBLE_EQ(rig.nodes->latched_velocity_rad_s(drive_node(0)), 0.2) << "step " << i;
  }
  EXPECT_EQ(rig.master->counters().target_expiries, 0u);
}

TEST(Pa10Master, LockStepSendsTargetsAndReadsPositionsOfTheSameSync) {
  MasterConfig config = test_config();
  config.target_expiry_periods = 0;  // one target for all 50 cycles
  Rig rig({}, config);
  rig.nodes->set_wrench(ForceSensor::wrist, {1.5, -2.25, 10.0, 0.125, -0.25, 0.5});
  rig.nodes->set_wrench(ForceSensor::joystick, {-3.0, 0.0, 4.0, 0.0, 0.0, -0.001});
  rig.master->start();
  std::array<double, kDriveCount> start_rad{};
  for (int j = 0; j < kDriveCount; ++j) start_rad[static_cast<std::size_t>(j)] = rig.nodes->position_rad(drive_node(j));

  const std::array<double, kDriveCount> target = {0.1, -0.2, 0.3, -0.4, 0.5, -0.6, 0.7};
  rig.master->set_target_velocities(target);
  constexpr int kSteps = 50;
  for (int i = 0; i < kSteps; ++i) ASSERT_TRUE(rig.master->step()) << "step " << i;

  const JointState s = rig.master->joint_state();
  EXPECT_TRUE(s.complete);
  EXPECT_EQ(s.sync_counter, rig.nodes->last_sync_counter());
  for (int j = 0; j < kDriveCount; ++j) {
    const auto i = static_cast<std::size_t>(j);
    EXPECT_EQ(rig.nodes->latched_controlword(drive_node(j)), controlword::kEnableOperation);
    EXPECT_DOUBLE_EQ(rig.nodes->latched_velocity_rad_s(drive_node(j)), target[i]);
    // Every SYNC the plant integrates 2 ms of the latched target; positions are in 1 µrad.
    EXPECT_NEAR(s.position_rad[i] - start_rad[i], target[i] * 0.002 * kSteps, 2e-6) << joint_name(j);
    EXPECT_NEAR(s.velocity_rad_s[i], target[i], 1e-3);
  }
  const Wrench w = rig.master->wrench(ForceSensor::wrist);
  ASSERT_TRUE(w.valid);
  EXPECT_EQ(w.sync_counter, s.sync_counter);
  EXPECT_NEAR(w.values[0], 1.5, 1e-9);
  EXPECT_NEAR(w.values[1], -2.25, 1e-9);
  EXPECT_NEAR(w.values[2], 10.0, 1e-9);
  EXPECT_NEAR(w.values[3], 0.125, 1e-9);
  EXPECT_NEAR(w.values[5], 0.5, 1e-9);
  const Wrench joy = rig.master->wrench(ForceSensor::joystick);
  EXPECT_NEAR(joy.values[0], -3.0, 1e-9);
  EXPECT_NEAR(joy.values[5], -0.001, 1e-9);
  EXPECT_GT(joy.sequence, static_cast<std::uint64_t>(kSteps - 1));
}

TEST(Pa10Master, ACycleAllocatesNothing) {
  Rig rig;
  rig.master->start();
  for (int i = 0; i < 10; ++i) rig.master->step();  // warm-up
  const std::size_t probe = rtm_test::allocations_on_this_thread();
  { std::vector<int> counted(100); }
  ASSERT_EQ(rtm_test::allocations_on_this_thread() - probe, 1u) << "the counter must see allocations";
  const std::size_t before = rtm_test::allocations_on_this_thread();
  for (int i = 0; i < 200; ++i) {
    rig.master->set_target_velocities({0.01 * i, 0, 0, 0, 0, 0, -0.01 * i});
    ASSERT_TRUE(rig.master->step());
    const JointState s = rig.master->joint_state();
    const Wrench w = rig.master->wrench(ForceSensor::wrist);
    ASSERT_TRUE(s.complete && w.valid);
  }
  EXPECT_EQ(rtm_test::allocations_on_this_thread() - before, 0u);
}

TEST(Pa10Master, SyncCounterWrapsFrom240To1) {
  Rig rig;
  rig.master->start();
  std::uint8_t previous = rig.master->joint_state().sync_counter;
  bool wrapped = false;
  for (int i = 0; i < 300; ++i) {
    ASSERT_TRUE(rig.master->step());
    const std::uint8_t now = rig.master->joint_state().sync_counter;
    EXPECT_EQ(now, next_sync_counter(previous));
    wrapped = wrapped || (previous == 240 && now == 1);
    previous = now;
  }
  EXPECT_TRUE(wrapped);
}

TEST(Pa10Master, DriveFaultLatchesFaultWithReasonAndCommandsZero) {
  Rig rig;
  rig.master->start();
  rig.master->set_target_velocities({0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5});
  for (int i = 0; i < 5; ++i) rig.master->step();
  EXPECT_DOUBLE_EQ(rig.nodes->latched_velocity_rad_s(drive_node(0)), 0.5);

  rig.nodes->inject_fault(drive_node(3));
  ASSERT_TRUE(step_until(*rig.master, [&] { return rig.master->fault().active(); }));
  const MasterFault f = rig.master->fault();
  EXPECT_EQ(f.node, 4);
  EXPECT_THAT(f.reason, HasSubstr("drive 4 (E1)"));
  EXPECT_TRUE(f.kind == FaultKind::emergency || f.kind == FaultKind::drive_fault) << to_string(f.kind);
  EXPECT_FALSE(rig.master->enabled());

  rig.master->set_target_velocities({1, 1, 1, 1, 1, 1, 1});  // ignored in fault
  for (int i = 0; i < 3; ++i) rig.master->step();
  for (int j = 0; j < kDriveCount; ++j) {
    EXPECT_EQ(rig.nodes->latched_velocity_rad_s(drive_node(j)), 0.0) << joint_name(j);
  }
  // Healthy drives are held enabled at zero, the faulted one stays in fault.
  EXPECT_EQ(rig.nodes->drive_state(drive_node(0)), DriveState::operation_enabled);
  EXPECT_EQ(rig.nodes->drive_state(drive_node(3)), DriveState::fault);
}

TEST(Pa10Master, FaultResetReenablesTheDriveAndKeepsTargetsZeroUntilSetAgain) {
  Rig rig;
  rig.master->start();
  rig.master->set_target_velocities({0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5});
  rig.master->step();
  rig.nodes->inject_fault(drive_node(6));
  ASSERT_TRUE(step_until(*rig.master, [&] { return rig.master->fault().active(); }));

  rig.master->fault_reset();
  ASSERT_TRUE(step_until(*rig.master, [&] { return rig.master->enabled(); }));
  EXPECT_FALSE(rig.master->fault().active());
  EXPECT_EQ(rig.nodes->drive_state(drive_node(6)), DriveState::operation_enabled);
  rig.master->step();
  EXPECT_EQ(rig.nodes->latched_velocity_rad_s(drive_node(0)), 0.0);  // old target forgotten

  rig.master->set_target_velocities({0.25, 0, 0, 0, 0, 0, 0});
  rig.master->step();
  rig.master->step();
  EXPECT_DOUBLE_EQ(rig.nodes->latched_velocity_rad_s(drive_node(0)), 0.25);
}

TEST(Pa10Master, AFaultResetThatDoesNotTakeRaisesTheFaultAgain) {
  MasterConfig config = test_config();
  config.enable_timeout_ns = 300'000'000;
  Rig rig({}, config);
  rig.master->start();
  rig.nodes->set_fault_persistent(drive_node(2));  // broken hardware: no reset takes
  rig.nodes->inject_fault(drive_node(2));
  ASSERT_TRUE(step_until(*rig.master, [&] { return rig.master->fault().active(); }));
  rig.master->fault_reset();
  rig.master->step();  // the master takes the reset up
  ASSERT_TRUE(eventually([&] {
    if (rig.master->fault().active()) return true;
    rig.master->step();
    return false;
  }));
  const MasterFault f = rig.master->fault();
  EXPECT_EQ(f.kind, FaultKind::drive_fault);
  EXPECT_THAT(f.reason, HasSubstr("fault reset failed: drive 3 (S3) still fault"));
  EXPECT_FALSE(rig.master->enabled());
  EXPECT_EQ(rig.nodes->drive_state(drive_node(0)), DriveState::operation_enabled);
}

TEST(Pa10Master, HeartbeatLossOfASensorIsAFaultNamingIt) {
  MasterConfig config = test_config();
  config.heartbeat_timeout_ns = 300'000'000;
  config.step_timeout_ns = 20'000'000;  // the silenced sensor's TPDOs stop too
  Rig rig({}, config);
  rig.master->start();
  rig.nodes->set_connected(kWristSensorNode, false);
  // Silence is measured on the wall clock: step until the master notices.
  const auto deadline = std::chrono::steady_clock::now() + 20s;
  while (!rig.master->fault().active() && std::chrono::steady_clock::now() < deadline) {
    rig.master->step();
    std::this_thread::sleep_for(2ms);
  }
  const MasterFault f = rig.master->fault();
  EXPECT_EQ(f.kind, FaultKind::heartbeat_lost);
  EXPECT_EQ(f.node, kWristSensorNode);
  EXPECT_THAT(f.reason, HasSubstr("wrist sensor 0x10"));
  EXPECT_THAT(f.reason, HasSubstr("no heartbeat"));
}

TEST(Pa10Master, MissingTpdosRaiseMissingFeedbackAfterTheLimit) {
  MasterConfig config = test_config();
  config.step_timeout_ns = 20'000'000;
  config.missed_feedback_limit = 3;
  Rig rig({}, config);
  rig.master->start();
  rig.nodes->set_connected(drive_node(1), false);
  ASSERT_TRUE(step_until(*rig.master, [&] { return rig.master->fault().active(); }, 50));
  EXPECT_EQ(rig.master->fault().kind, FaultKind::missing_feedback);
  EXPECT_THAT(rig.master->fault().reason, HasSubstr("drive 2 (S2)"));
  EXPECT_GE(rig.master->counters().step_timeouts, 4u);
}

// A silent drive counts only in windows the master closed on time: when its own cycle ran late
// (its process or the host stalled, and the nodes may have stalled with it) the silence is not
// the drive's. The cycles are run by hand here, as a tick that took them over runs them.
TEST(Pa10Master, SilenceInWindowsTheMasterClosedLateIsNotCountedAsMissingFeedback) {
  MasterConfig config = test_config();
  config.missed_feedback_limit = 3;
  Rig rig({}, config);
  rig.master->start();
  ASSERT_EQ(rig.master->take_over_cycles(), 0);
  rig.nodes->set_connected(drive_node(3), false);
  for (int i = 0; i < 10; ++i) {  // each window 10 ms long: five periods, the master was late
    rig.master->transmit_cycle();
    std::this_thread::sleep_for(10ms);
    rig.master->receive_cycle();
  }
  EXPECT_FALSE(rig.master->fault().active()) << rig.master->fault().reason;
  EXPECT_GE(rig.master->counters().stalled_windows, 10u);
  // On time (the receive within 1.5 periods of the SYNC), the same silence is a fault. The
  // window closes once the nodes have answered the SYNC (they answer under the lock that
  // syncs_seen() takes) and the hub had a moment to pass the answers on: beside other work the
  // nodes' thread can be held off for longer than a period, and the answering drives must not
  // be blamed for that. A window that waited too long is late and not counted.
  for (int i = 0; i < 2000 && !rig.master->fault().active(); ++i) {
    const std::uint64_t seen = rig.nodes->syncs_seen();
    rig.master->transmit_cycle();
    const auto give_up = std::chrono::steady_clock::now() + 1s;
    while (rig.nodes->syncs_seen() == seen && std::chrono::steady_clock::now() < give_up)
      std::this_thread::sleep_for(50us);
    std::this_thread::sleep_for(300us);
    rig.master->receive_cycle();
  }
  EXPECT_EQ(rig.master->fault().kind, FaultKind::missing_feedback) << rig.master->fault().reason;
  EXPECT_THAT(rig.master->fault().reason, HasSubstr("drive 4 (E1)"));
}

// After a quick stop the master released, a drive still reporting quick stop active is where
// the master put it, for the whole grace (enable_timeout_ns): the answer can be one that a stall
// made late, carrying the state of a SYNC before the release, even after every drive already
// reported operation enabled. Past the grace it is a drive that left operation enabled.
TEST(Supervisor, AQuickStopActiveAnswerWithinTheGraceAfterTheReleaseIsNoFaultAfterItIs) {
  const MasterConfig config = test_config();
  std::array<bool, 128> expected{};
  for (int j = 0; j < kDriveCount; ++j) expected[drive_node(j)] = true;
  Supervisor supervisor(config, expected);
  std::int64_t t = 1'000'000'000;
  supervisor.on_nmt_start(t);
  supervisor.enabled_at_startup();
  std::array<bool, kDriveCount> got{};
  got.fill(true);
  std::array<std::uint16_t, kDriveCount> enabled{}, quick_stopped{};
  enabled.fill(statusword::kOperationEnabled);
  quick_stopped.fill(statusword::kQuickStopActive);
  supervisor.check_drives(got, enabled, t += 2'000'000, true);
  supervisor.take_quick_stop(true, t);
  supervisor.check_drives(got, quick_stopped, t += 2'000'000, true);
  supervisor.take_quick_stop(false, t);
  supervisor.check_drives(got, enabled, t += 2'000'000, true);  // every drive enabled again
  std::array<std::uint16_t, kDriveCount> late = enabled;
  late[0] = statusword::kQuickStopActive;  // S1's answer to a SYNC before the release, late
  supervisor.check_drives(got, late, t += 2'000'000, true);
  EXPECT_FALSE(supervisor.faulted()) << supervisor.fault().reason.data();
  supervisor.check_drives(got, late, t += config.enable_timeout_ns, true);
  EXPECT_EQ(supervisor.fault().kind, FaultKind::drive_disabled);
  EXPECT_THAT(std::string(supervisor.fault().reason.data()), HasSubstr("drive 1 (S1)"));
}

TEST(Pa10Master, ATpdoMissingForOneSyncKeepsTheDrivesEnabledAndTheTargetFlowing) {
  MasterConfig config = test_config();
  config.step_timeout_ns = 20'000'000;  // the step waits for the dropped TPDO this long
  Rig rig({}, config);
  rig.master->start();
  ASSERT_TRUE(rig.master->step());
  rig.nodes->lose_next_tpdo(drive_node(3));
  rig.master->set_target_velocities({0, 0, 0, 0.2, 0, 0, 0});
  EXPECT_FALSE(rig.master->step()) << "the step saw the TPDO missing";
  EXPECT_FALSE(rig.master->joint_state().complete);
  EXPECT_TRUE(rig.master->enabled()) << "a late TPDO (a host stall) is no reason to stop the arm";
  EXPECT_FALSE(rig.master->fault().active()) << rig.master->fault().reason;
  ASSERT_TRUE(rig.master->step());
  EXPECT_TRUE(rig.master->enabled());
  EXPECT_DOUBLE_EQ(rig.nodes->latched_velocity_rad_s(drive_node(3)), 0.2);
}

// A TPDO nobody asked for, a second master and an SDO write are faults: master_attack_test.cpp.
TEST(Pa10Master, UnknownMalformedFramesAndAForeignSdoReadAreCountedAndIgnored) {
  Rig rig;
  rig.master->start();
  auto intruder = open_bus(rig.spec);
  const MasterCounters before = rig.master->counters();

  can_frame unknown{};
  unknown.can_id = 0x123;
  unknown.can_dlc = 2;
  can_frame malformed{};
  malformed.can_id = 0x181;  // drive TPDO1 with 3 bytes instead of 8
  malformed.can_dlc = 3;
  can_frame impossible_dlc{};
  impossible_dlc.can_id = 0x190;
  impossible_dlc.can_dlc = 200;
  const can_frame foreign = *encode_sdo_request({0x30, SdoRequestKind::upload, 0x1000, 0, 0, 0});  // to nobody
  for (const can_frame& f : {unknown, malformed, impossible_dlc, foreign}) intruder->send(f);
  ASSERT_TRUE(delivered(*intruder));
  for (int i = 0; i < 5; ++i) ASSERT_TRUE(rig.master->step());

  const MasterCounters after = rig.master->counters();
  EXPECT_EQ(after.unknown_frames - before.unknown_frames, 1u);
  EXPECT_EQ(after.malformed_frames - before.malformed_frames, 1u);  // the hub drops DLC 200
  EXPECT_EQ(after.foreign_frames - before.foreign_frames, 1u);
  EXPECT_FALSE(rig.master->fault().active());
  EXPECT_TRUE(rig.master->enabled());
}

TEST(Pa10Master, RpdoTimeoutEmcyFromADriveIsACommandLossNamingTheCause) {
  Rig rig;
  rig.master->start();
  auto drive_side = open_bus(rig.spec);
  drive_side->send(*encode_emcy(2, emcy::kRpdoTimeout, 0x11));
  ASSERT_TRUE(step_until(*rig.master, [&] { return rig.master->fault().active(); }));
  const MasterFault f = rig.master->fault();
  EXPECT_EQ(f.kind, FaultKind::command_loss) << to_string(f.kind);
  EXPECT_EQ(f.code, emcy::kRpdoTimeout);
  EXPECT_EQ(f.reason, "drive 2 (S2): EMCY 0x8250 RPDO timeout (command loss)");
}

TEST(Pa10Master, QuickStopBrakesEveryDriveWithoutAFaultAndATargetResumesOperation) {
  Rig rig;
  rig.master->start();
  rig.master->set_target_velocities({0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5});
  for (int i = 0; i < 3; ++i) rig.master->step();
  ASSERT_DOUBLE_EQ(rig.nodes->latched_velocity_rad_s(drive_node(0)), 0.5);

  rig.master->quick_stop();
  ASSERT_TRUE(step_until(*rig.master, [&] { return rig.master->quick_stopped(); }, 20));
  for (int j = 0; j < kDriveCount; ++j) {
    EXPECT_EQ(rig.nodes->drive_state(drive_node(j)), DriveState::quick_stop_active) << joint_name(j);
    EXPECT_EQ(rig.nodes->latched_controlword(drive_node(j)), controlword::kQuickStop) << joint_name(j);
    EXPECT_EQ(rig.nodes->latched_velocity_rad_s(drive_node(j)), 0.0) << joint_name(j);
  }
  const double braked_at_rad = rig.nodes->position_rad(drive_node(0));
  for (int i = 0; i < 10; ++i) rig.master->step();
  EXPECT_EQ(rig.nodes->position_rad(drive_node(0)), braked_at_rad) << "held on the brake";
  EXPECT_FALSE(rig.master->fault().active()) << rig.master->fault().reason;
  EXPECT_TRUE(rig.master->enabled()) << "ready to move on the next target";
  EXPECT_TRUE(rig.master->quick_stopped());

  rig.master->set_target_velocities({0.25, 0, 0, 0, 0, 0, 0});
  rig.master->step();
  EXPECT_FALSE(rig.master->quick_stopped());
  EXPECT_EQ(rig.nodes->latched_controlword(drive_node(0)), controlword::kEnableOperation);
  EXPECT_EQ(rig.nodes->drive_state(drive_node(0)), DriveState::operation_enabled);
  EXPECT_DOUBLE_EQ(rig.nodes->latched_velocity_rad_s(drive_node(0)), 0.25) << "moves in the same cycle";
  for (int i = 0; i < 10; ++i) rig.master->step();
  EXPECT_FALSE(rig.master->fault().active()) << rig.master->fault().reason;
  EXPECT_TRUE(rig.master->enabled());
}

TEST(Pa10Master, QuickStopDuringAFaultIsIgnoredAndFaultResetEndsIt) {
  Rig rig;
  rig.master->start();
  rig.nodes->inject_fault(drive_node(1));
  ASSERT_TRUE(step_until(*rig.master, [&] { return rig.master->fault().active(); }));
  rig.master->quick_stop();
  for (int i = 0; i < 3; ++i) rig.master->step();
  EXPECT_FALSE(rig.master->quick_stopped());
  EXPECT_EQ(rig.nodes->drive_state(drive_node(0)), DriveState::operation_enabled) << "held enabled at zero";
  rig.master->fault_reset();
  ASSERT_TRUE(step_until(*rig.master, [&] { return rig.master->enabled(); }));
  EXPECT_FALSE(rig.master->quick_stopped());
  EXPECT_EQ(rig.nodes->drive_state(drive_node(1)), DriveState::operation_enabled);
}

TEST(Pa10Master, EmcyErrorResetAndOtherNodesEmcyAreNoFault) {
  Rig rig;
  rig.master->start();
  auto other = open_bus(rig.spec);
  other->send(*encode_emcy(3, emcy::kErrorReset, 0));
  other->send(*encode_emcy(0x42, emcy::kDeviceHardware, 0x01));  // not a PA10 node
  for (int i = 0; i < 20; ++i) ASSERT_TRUE(rig.master->step());
  EXPECT_FALSE(rig.master->fault().active()) << rig.master->fault().reason;
  EXPECT_EQ(rig.master->counters().emcy_frames, 2u);
}

TEST(Pa10Master, HeartbeatReportingPreOperationalAfterStartIsAFault) {
  MasterConfig config = test_config();
  config.heartbeat_timeout_ns = 1'000'000'000;  // also the grace period after NMT start
  Rig rig({}, config);
  rig.master->start();
  std::this_thread::sleep_for(1100ms);  // past the grace period; not an assertion on timing
  auto other = open_bus(rig.spec);
  other->send(*encode_heartbeat(5, NmtState::pre_operational));
  ASSERT_TRUE(step_until(*rig.master, [&] { return rig.master->fault().active(); }));
  EXPECT_EQ(rig.master->fault().kind, FaultKind::node_not_operational) << rig.master->fault().reason;
  EXPECT_THAT(rig.master->fault().reason, HasSubstr("drive 5 (E2): heartbeat reports pre-operational"));
}

TEST(Pa10Master, SetTargetVelocitiesRejectsNaNAndInfinityNamingTheJoint) {
  Rig rig;
  EXPECT_THAT([&] { rig.master->set_target_velocities({0, 0, NAN, 0, 0, 0, 0}); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("S3")));
  EXPECT_THROW(rig.master->set_target_velocities({0, 0, 0, 0, 0, 0, INFINITY}), std::invalid_argument);
}

TEST(Pa10Master, StepBeforeStartIsALogicError) {
  Rig rig;
  EXPECT_THROW(rig.master->step(), std::logic_error);
}

TEST(Pa10Master, PeriodicThreadCyclesAndFollowsTargets) {
  Rig rig;
  rig.master->start();
  rig.master->set_target_velocities({0.2, 0, 0, 0, 0, 0, -0.2});
  const double start_rad = rig.nodes->position_rad(drive_node(0));
  rig.master->run_periodic();
  EXPECT_TRUE(rig.master->running());
  ASSERT_TRUE(eventually([&] { return rig.master->counters().cycles >= 100; }));
  rig.master->stop();
  EXPECT_FALSE(rig.master->running());
  EXPECT_GE(rig.master->counters().cycles, 100u);
  EXPECT_GT(rig.nodes->position_rad(drive_node(0)), start_rad);
  EXPECT_LT(rig.nodes->position_rad(drive_node(6)), 0.0);
  EXPECT_FALSE(rig.master->fault().active()) << rig.master->fault().reason;
}

std::int64_t realtime_now_ns() {
  timespec t{};
  clock_gettime(CLOCK_REALTIME, &t);
  return std::int64_t{t.tv_sec} * 1'000'000'000 + t.tv_nsec;
}

TEST(Pa10Master, EachTargetGetsTheNextSequenceNumber) {
  Rig rig;
  rig.master->start();
  EXPECT_EQ(rig.master->target_sequence(), 0u);
  EXPECT_EQ(rig.master->set_target_velocities({0.1, 0, 0, 0, 0, 0, 0}), 1u);
  EXPECT_EQ(rig.master->set_target_velocities({0.2, 0, 0, 0, 0, 0, 0}), 2u);
  EXPECT_EQ(rig.master->target_sequence(), 2u);
}

TEST(Pa10Master, LastSentIsPublishedByTheCycleThatWroteTheTargetNeverBefore) {
  Rig rig;
  rig.master->start();
  ASSERT_TRUE(rig.master->step());
  EXPECT_EQ(rig.master->last_sent().sequence, 0u) << "no target set yet";
  EXPECT_EQ(rig.master->last_sent().sent_realtime_ns, 0);

  const std::array<double, kDriveCount> first = {0.1, -0.1, 0.1, -0.1, 0.1, -0.1, 0.1};
  const std::uint64_t first_seq = rig.master->set_target_velocities(first);
  EXPECT_EQ(rig.master->last_sent().sequence, 0u) << "set, but no cycle has written it yet";
  const std::int64_t before_ns = realtime_now_ns();
  ASSERT_TRUE(rig.master->step());
  const std::int64_t after_ns = realtime_now_ns();
  const Pa10Master::SentTarget sent = rig.master->last_sent();
  EXPECT_EQ(sent.sequence, first_seq);
  EXPECT_GE(sent.sent_realtime_ns, before_ns);
  EXPECT_LE(sent.sent_realtime_ns, after_ns);
  // The drives did receive that target in this cycle's RPDOs.
  EXPECT_DOUBLE_EQ(rig.nodes->latched_velocity_rad_s(drive_node(0)), first[0]);

  const std::uint64_t second_seq = rig.master->set_target_velocities({0.3, 0, 0, 0, 0, 0, 0});
  EXPECT_EQ(second_seq, first_seq + 1);
  EXPECT_EQ(rig.master->last_sent().sequence, first_seq) << "the second target has not been written yet";
  ASSERT_TRUE(rig.master->step());
  const Pa10Master::SentTarget second = rig.master->last_sent();
  EXPECT_EQ(second.sequence, second_seq);
  EXPECT_GE(second.sent_realtime_ns, sent.sent_realtime_ns);
  ASSERT_TRUE(rig.master->step());
  EXPECT_EQ(rig.master->last_sent().sequence, second_seq) << "a repeated target keeps its sequence";
}

TEST(Pa10Master, CyclesSendingZeroInsteadOfTheTargetDoNotPublishItAsSent) {
  Rig rig;
  rig.master->start();
  const std::uint64_t seq = rig.master->set_target_velocities({0.1, 0, 0, 0, 0, 0, 0});
  ASSERT_TRUE(rig.master->step());
  ASSERT_EQ(rig.master->last_sent().sequence, seq);
  const std::int64_t sent_ns = rig.master->last_sent().sent_realtime_ns;
  rig.master->quick_stop();
  for (int i = 0; i < 3; ++i) rig.master->step();
  EXPECT_EQ(rig.master->last_sent().sequence, seq);
  EXPECT_EQ(rig.master->last_sent().sent_realtime_ns, sent_ns) << "quick stop cycles send zero, not the target";
}

TEST(Pa10Master, PeriodicGridDeadlinesAreWholePeriodsApartAndZeroWhenStopped) {
  Rig rig;
  rig.master->start();
  EXPECT_EQ(rig.master->next_cycle_deadline_ns(), 0);
  rig.master->run_periodic();
  const auto wait_cycles = [&](std::uint64_t n) {
    const std::uint64_t start = rig.master->counters().cycles;
    eventually([&] { return rig.master->counters().cycles >= start + n; });
  };
  wait_cycles(2);
  const std::int64_t first_ns = rig.master->next_cycle_deadline_ns();
  wait_cycles(5);
  const std::int64_t later_ns = rig.master->next_cycle_deadline_ns();
  rig.master->stop();
  const std::int64_t period_ns = rig.master->period_ns();
  ASSERT_GT(first_ns, 0);
  EXPECT_GT(later_ns, first_ns);
  // Overruns skip whole periods: the grid never shifts.
  EXPECT_EQ((later_ns - first_ns) % period_ns, 0) << "first " << first_ns << " later " << later_ns;
  EXPECT_EQ(rig.master->next_cycle_deadline_ns(), 0);
}

// Runs the cycle as a shared tick would: receive, (work), transmit, then waits until every
// answer to that SYNC is queued at the master (the nodes answer on their own thread), so the
// next receive finds them: lock-step, as a shared tick finds them a period later. The answers
// are those a probe sees after the SYNC itself (a node answers a SYNC once it has read it);
// what the probe had before is an earlier cycle's.
bool external_cycle(Rig& rig, const std::function<void()>& work = [] {}) {
  auto probe = open_bus(rig.spec);
  if (!probe->fence(kLockStepBound_ns)) return false;  // the hub serves it before the SYNC leaves
  can_frame earlier{};
  while (probe->receive(earlier, 0)) {
  }
  rig.master->receive_cycle();
  work();
  const std::uint64_t syncs = rig.nodes->syncs_seen();
  rig.master->transmit_cycle();
  return all_seen_and_delivered(*probe, {cob::kSync}) && all_seen_and_delivered(*probe, sync_answers()) &&
         rig.nodes->syncs_seen() > syncs;
}

TEST(Pa10MasterTakeOver, ATargetSetBetweenReceiveAndTransmitLeavesWithThatCyclesSync) {
  Rig rig;
  rig.master->start();
  EXPECT_EQ(rig.master->take_over_cycles(), 0) << "no periodic thread: nothing to wait for";
  EXPECT_TRUE(rig.master->cycles_taken_over());
  ASSERT_TRUE(external_cycle(rig));
  for (int k = 1; k <= 5; ++k) {
    const double v = 0.05 * k;
    std::uint64_t seq = 0;
    std::uint8_t answered = 0;
    ASSERT_TRUE(external_cycle(rig, [&] {
      answered = rig.master->joint_state().sync_counter;
      seq = rig.master->set_target_velocities({v, 0, 0, 0, 0, 0, -v});
    }));
    // receive_cycle() published the answers to the SYNC the previous transmit sent...
    EXPECT_EQ(next_sync_counter(answered), rig.nodes->last_sync_counter()) << "cycle " << k;
    // ...and transmit_cycle() sent the target set after it, in this cycle's RPDOs.
    EXPECT_EQ(rig.master->last_sent().sequence, seq) << "cycle " << k;
    EXPECT_DOUBLE_EQ(rig.nodes->latched_velocity_rad_s(drive_node(0)), v) << "cycle " << k;
    EXPECT_DOUBLE_EQ(rig.nodes->latched_velocity_rad_s(drive_node(6)), -v) << "cycle " << k;
  }
  EXPECT_FALSE(rig.master->fault().active()) << rig.master->fault().reason;
}

TEST(Pa10MasterTakeOver, CycleHalvesWithoutTakeOverAreALogicErrorAndStepIsRefusedWhileTakenOver) {
  Rig rig;
  EXPECT_THROW(rig.master->take_over_cycles(), std::logic_error) << "before start()";
  rig.master->start();
  EXPECT_THROW(rig.master->receive_cycle(), std::logic_error);
  EXPECT_THROW(rig.master->transmit_cycle(), std::logic_error);
  rig.master->take_over_cycles();
  EXPECT_THROW(rig.master->step(), std::logic_error);
  EXPECT_THROW(rig.master->run_periodic(), std::logic_error);
  rig.master->hand_back_cycles(0);
  EXPECT_FALSE(rig.master->cycles_taken_over());
  EXPECT_THROW(rig.master->receive_cycle(), std::logic_error) << "handed back";
  EXPECT_TRUE(rig.master->step());
}

// Waits until the periodic thread has sent n more SYNCs.
void wait_cycles(Pa10Master& m, std::uint64_t n) {
  const std::uint64_t start = m.counters().cycles;
  eventually([&] { return m.counters().cycles >= start + n; });
}

// These tests pause the owner on purpose: the take-back of a silent owner is off.
MasterConfig patient_config() {
  MasterConfig c = test_config();
  c.taken_over_timeout_periods = 0;
  return c;
}

TEST(Pa10MasterTakeOver, ThePeriodicThreadIdlesWhileTakenOverAndResumesOnTheDeadlineHandedBack) {
  Rig rig({}, patient_config());
  rig.master->start();
  rig.master->run_periodic();
  wait_cycles(*rig.master, 3);
  const std::int64_t grid_ns = rig.master->next_cycle_deadline_ns();
  const std::int64_t period_ns = rig.master->period_ns();
  const std::int64_t first_ns = rig.master->take_over_cycles();
  ASSERT_GT(first_ns, 0);
  EXPECT_EQ((first_ns - grid_ns) % period_ns, 0) << "the caller's first cycle is due on the thread's grid";
  EXPECT_EQ(rig.master->take_over_cycles(), first_ns) << "idempotent";
  EXPECT_EQ(rig.master->next_cycle_deadline_ns(), 0);

  // The thread sends nothing now: only the caller's cycles reach the drives. (Its last SYNC,
  // sent just before it idled, may still be on its way to the nodes.)
  std::this_thread::sleep_for(5ms);
  const std::uint64_t syncs = rig.nodes->syncs_seen();
  std::this_thread::sleep_for(20ms);
  EXPECT_EQ(rig.nodes->syncs_seen(), syncs) << "the idle thread sent SYNCs";
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(external_cycle(rig));
  EXPECT_EQ(rig.nodes->syncs_seen(), syncs + 3);

  // Handed back 50 ms ahead: the thread's next cycle is due exactly then, and it cycles again.
  timespec now{};
  clock_gettime(CLOCK_MONOTONIC, &now);
  const std::int64_t back_ns = std::int64_t{now.tv_sec} * 1'000'000'000 + now.tv_nsec + 50'000'000;
  rig.master->hand_back_cycles(back_ns);
  EXPECT_FALSE(rig.master->cycles_taken_over());
  EXPECT_EQ(rig.master->next_cycle_deadline_ns(), back_ns);
  wait_cycles(*rig.master, 5);
  // The last SYNC may be in transit.
  ASSERT_TRUE(eventually([&] { return rig.nodes->syncs_seen() >= syncs + 3 + 5; }));
  EXPECT_GE(rig.nodes->syncs_seen(), syncs + 3 + 5);
  EXPECT_EQ((rig.master->next_cycle_deadline_ns() - back_ns) % period_ns, 0) << "on the grid handed back";
  EXPECT_FALSE(rig.master->fault().active()) << rig.master->fault().reason;
  rig.master->stop();
}

TEST(Pa10MasterTakeOver, StopWhileTakenOverEndsTheIdleThreadAndTheCallerKeepsTheCycles) {
  Rig rig;
  rig.master->start();
  rig.master->run_periodic();
  wait_cycles(*rig.master, 2);
  rig.master->take_over_cycles();
  rig.master->stop();  // must not hang on the idle thread
  EXPECT_FALSE(rig.master->running());
  EXPECT_TRUE(rig.master->cycles_taken_over());
  EXPECT_TRUE(external_cycle(rig));
  rig.master->hand_back_cycles(0);  // nobody to hand back to: the cycles are simply released
  EXPECT_FALSE(rig.master->cycles_taken_over());
  EXPECT_TRUE(rig.master->step());
}

TEST(Pa10MasterTakeOver, ASilentOwnerLosesTheCyclesToTheMastersThreadWithAFaultAndZeroVelocity) {
  Rig rig;
  rig.master->start();
  rig.master->run_periodic();
  wait_cycles(*rig.master, 2);
  const std::int64_t handover_ns = rig.master->take_over_cycles();
  ASSERT_GT(handover_ns, 0);
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(external_cycle(rig, [&] { rig.master->set_target_velocities({0.3, 0, 0, 0, 0, 0, 0}); }));
  }
  ASSERT_DOUBLE_EQ(rig.nodes->latched_velocity_rad_s(drive_node(0)), 0.3);
  // The owner stops: no more receive/transmit. The idle thread must notice and take over.
  ASSERT_TRUE(eventually([&] { return rig.master->fault().active(); }));
  const MasterFault f = rig.master->fault();
  EXPECT_EQ(f.kind, FaultKind::cycle_owner_lost) << f.reason;
  EXPECT_THAT(f.reason, HasSubstr("took them back"));
  EXPECT_FALSE(rig.master->cycles_taken_over());
  // The emulated drive latches what the master's thread sends: zero, within a few of its cycles
  // (waited for, not slept: a loaded machine runs them late).
  EXPECT_TRUE(eventually([&] { return rig.nodes->latched_velocity_rad_s(drive_node(0)) == 0.0; }))
      << "the master's thread sends zero; the drive still latches " << rig.nodes->latched_velocity_rad_s(drive_node(0));
  EXPECT_FALSE(rig.master->receive_cycle()) << "the cycles are no longer the caller's";
  EXPECT_FALSE(rig.master->transmit_cycle());
  rig.master->hand_back_cycles(0);  // nothing to hand back
  const std::int64_t next_ns = rig.master->next_cycle_deadline_ns();
  EXPECT_GT(next_ns, 0) << "the master's thread runs the grid";
  EXPECT_EQ((next_ns - handover_ns) % rig.master->period_ns(), 0) << "on the grid the owner had";
  rig.master->stop();
}

// A stall, not a dead owner: the owner comes back, takes the cycles again from the master's
// next deadline (on its own grid), resets the fault and the drives follow its targets again.
TEST(Pa10MasterTakeOver, AnOwnerThatLostTheCyclesTakesThemAgainAndAFaultResetMovesTheArm) {
  Rig rig;
  rig.master->start();
  rig.master->run_periodic();
  wait_cycles(*rig.master, 2);
  const std::int64_t handover_ns = rig.master->take_over_cycles();
  ASSERT_TRUE(external_cycle(rig, [&] { rig.master->set_target_velocities({0.3, 0, 0, 0, 0, 0, 0}); }));
  ASSERT_TRUE(eventually([&] { return rig.master->fault().active(); }));
  ASSERT_EQ(rig.master->fault().kind, FaultKind::cycle_owner_lost) << rig.master->fault().reason;
  ASSERT_FALSE(rig.master->receive_cycle()) << "the cycles are the master's thread's now";
  const std::int64_t again_ns = rig.master->take_over_cycles();
  EXPECT_TRUE(rig.master->cycles_taken_over());
  EXPECT_GT(again_ns, handover_ns);
  EXPECT_EQ((again_ns - handover_ns) % rig.master->period_ns(), 0) << "the owner's grid goes on";
  rig.master->fault_reset();
  bool moving = false;
  for (int i = 0; i < 200 && !moving; ++i) {
    ASSERT_TRUE(external_cycle(rig, [&] {
      if (!rig.master->fault().active()) rig.master->set_target_velocities({0.2, 0, 0, 0, 0, 0, 0});
    }));
    moving = std::abs(rig.nodes->latched_velocity_rad_s(drive_node(0)) - 0.2) < 1e-6;
  }
  EXPECT_TRUE(moving) << rig.master->fault().reason;
  EXPECT_FALSE(rig.master->fault().active()) << rig.master->fault().reason;
  rig.master->hand_back_cycles(0);
  rig.master->stop();
}

TEST(Pa10MasterTakeOver, WithTheTimeoutOffASilentOwnerKeepsTheCycles) {
  Rig rig({}, patient_config());
  rig.master->start();
  rig.master->run_periodic();
  wait_cycles(*rig.master, 2);
  rig.master->take_over_cycles();
  std::this_thread::sleep_for(50ms);  // 25 periods without a transmit
  EXPECT_TRUE(rig.master->cycles_taken_over());
  EXPECT_FALSE(rig.master->fault().active()) << rig.master->fault().reason;
  EXPECT_TRUE(rig.master->receive_cycle());
  rig.master->hand_back_cycles(0);
  rig.master->stop();
}

TEST(Pa10MasterTakeOver, RepeatedTakeOverAndHandBackNeverLeavesTwoThreadsCycling) {
  Rig rig({}, patient_config());
  rig.master->start();
  rig.master->run_periodic();
  // The nodes' SYNC count once no SYNC has arrived for 10 periods: the thread's last one, sent
  // before take_over_cycles() returned, has then reached them, however late the host let it
  // (a fixed wait was too short under TSan). 0 if SYNCs kept coming for 5 s: a thread cycling.
  const auto settled_syncs = [&] {
    const auto deadline = std::chrono::steady_clock::now() + 5s;
    std::uint64_t seen = rig.nodes->syncs_seen();
    while (std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(20ms);
      const std::uint64_t now = rig.nodes->syncs_seen();
      if (now == seen) return seen;
      seen = now;
    }
    return std::uint64_t{0};
  };
  for (int round = 0; round < 20; ++round) {
    rig.master->take_over_cycles();
    const std::uint64_t syncs = settled_syncs();
    ASSERT_NE(syncs, 0u) << "round " << round << ": SYNCs kept coming after the cycles were taken over";
    ASSERT_TRUE(external_cycle(rig)) << "round " << round;
    EXPECT_EQ(rig.nodes->syncs_seen(), syncs + 1) << "round " << round << ": the idle thread sent a SYNC";
    rig.master->hand_back_cycles(0);
  }
  wait_cycles(*rig.master, 3);
  rig.master->stop();
  EXPECT_FALSE(rig.master->fault().active()) << rig.master->fault().reason;
}

TEST(Pa10Master, PeriodicThreadCountsOverrunsWhenCyclesOutlastThePeriod) {
  Rig rig;
  rig.master->start();
  // A 1 µs period: every cycle (8 frames out, a drain in) ends after its next deadline.
  rig.master->run_periodic(1'000);
  ASSERT_TRUE(eventually([&] { return rig.master->counters().cycles >= 50; }));
  rig.master->stop();
  const MasterCounters c = rig.master->counters();
  EXPECT_GE(c.cycles, 50u);
  EXPECT_GT(c.overruns, 0u);
  EXPECT_LE(c.overruns, c.cycles);
  EXPECT_THROW(rig.master->run_periodic(0), std::invalid_argument);
}

TEST(Pa10Master, DestructionLeavesDrivesSwitchedOffAndPreOperational) {
  TempDir dir;
  LocalHub hub(dir.file("bus"));
  auto master = std::make_unique<Pa10Master>(open_bus("local:" + dir.file("bus")), nullptr, test_config());
  EmulatedPa10 nodes("local:" + dir.file("bus"));
  master->start();
  master->step();
  master.reset();
  const auto all_pre_operational = [&] {
    for (int j = 0; j < kDriveCount; ++j)
      if (nodes.nmt_state(drive_node(j)) != NmtState::pre_operational) return false;
    return nodes.nmt_state(kWristSensorNode) == NmtState::pre_operational &&
           nodes.nmt_state(kJoystickSensorNode) == NmtState::pre_operational;
  };
  ASSERT_TRUE(eventually(all_pre_operational));
  EXPECT_TRUE(all_pre_operational());
  for (int j = 0; j < kDriveCount; ++j)
    EXPECT_EQ(nodes.drive_state(drive_node(j)), DriveState::ready_to_switch_on) << joint_name(j);
}

TEST(Pa10Master, SensorsOnASeparateBusGetTheirOwnSyncAndNmt) {
  TempDir dir;
  LocalHub drive_hub(dir.file("drives"));
  LocalHub sensor_hub(dir.file("sensors"));
  Pa10Master master("local:" + dir.file("drives"), "local:" + dir.file("sensors"), test_config());
  EmulatedPa10::Options options;
  options.sensor_bus = "local:" + dir.file("sensors");
  EmulatedPa10 nodes("local:" + dir.file("drives"), options);
  nodes.set_wrench(ForceSensor::joystick, {5.0, 0, 0, 0, 0, 0});
  master.start();
  ASSERT_TRUE(master.step());
  EXPECT_EQ(master.sensor_bus_name(), "local:" + dir.file("sensors"));
  EXPECT_EQ(nodes.nmt_state(kJoystickSensorNode), NmtState::operational);
  EXPECT_EQ(nodes.nmt_state(kWristSensorNode), NmtState::operational);
  EXPECT_EQ(nodes.last_sensor_sync_counter(ForceSensor::joystick), master.joint_state().sync_counter);
  EXPECT_EQ(nodes.last_sync_counter(), master.joint_state().sync_counter) << "the same SYNC on both buses";
  EXPECT_NEAR(master.wrench(ForceSensor::joystick).values[0], 5.0, 1e-9);
}

TEST(CanSensorListener, ReadsTheWrenchAndItsSyncCounterPassively) {
  Rig rig;
  rig.nodes->set_wrench(ForceSensor::joystick, {7.0, -1.0, 0.5, 0.01, 0.02, -0.03});
  SensorListener listener(rig.spec, ForceSensor::joystick);
  listener.start();
  rig.master->start();
  for (int i = 0; i < 10; ++i) ASSERT_TRUE(rig.master->step());
  const auto w = listener.wait_newer_than(0, 5'000'000'000);
  ASSERT_TRUE(w.has_value());
  EXPECT_TRUE(w->valid);
  EXPECT_NEAR(w->values[0], 7.0, 1e-9);
  EXPECT_NEAR(w->values[5], -0.03, 1e-9);
  EXPECT_GE(w->sync_counter, 1);
  EXPECT_LE(w->sync_counter, 240);
  // Wait for the last SYNC's wrench: then both sides name the same SYNC.
  const std::uint8_t master_counter = rig.master->wrench(ForceSensor::joystick).sync_counter;
  ASSERT_TRUE(eventually([&] { return listener.latest().sync_counter == master_counter; }));
  EXPECT_EQ(listener.latest().sync_counter, master_counter);
  EXPECT_FALSE(listener.fault().active()) << listener.fault().reason;
  listener.stop();
}

TEST(CanSensorListener, PollModeAndEmcyFaultUntilTheErrorReset) {
  TempDir dir;
  LocalHub hub(dir.file("bus"));
  SensorListener listener(open_bus("local:" + dir.file("bus")), kWristSensorNode);
  auto device = open_bus("local:" + dir.file("bus"));
  device->send(*encode_sync(17));
  device->send(*encode_sensor_force({kWristSensorNode, {1, 2, 3}}));
  device->send(*encode_sensor_force({kJoystickSensorNode, {9, 9, 9}}));  // another node: ignored
  device->send(*encode_sensor_torque({kWristSensorNode, {0.1, 0.2, 0.3}}));
  ASSERT_TRUE(listener.poll(5'000'000'000));
  const Wrench w = listener.latest();
  EXPECT_EQ(w.sync_counter, 17);
  EXPECT_NEAR(w.values[2], 3.0, 1e-9);
  EXPECT_NEAR(w.values[4], 0.2, 1e-9);

  device->send(*encode_emcy(kWristSensorNode, emcy::kSensorFault, 0x80));
  device->send(*encode_sync(18));  // gives poll a frame after the EMCY to return on
  listener.poll(200'000'000);
  EXPECT_THAT(listener.fault().reason, HasSubstr("EMCY 0x7300"));
  EXPECT_THAT(listener.fault().reason, HasSubstr("wrist sensor 0x10"));
  EXPECT_EQ(listener.fault_kind(), FaultKind::emergency);
  device->send(*encode_emcy(kWristSensorNode, emcy::kErrorReset, 0x00));  // the sensor's error reset
  device->send(*encode_sync(19));
  listener.poll(200'000'000);
  EXPECT_EQ(listener.fault_kind(), FaultKind::none);
  EXPECT_FALSE(listener.fault().active()) << listener.fault().reason;
  EXPECT_THROW(SensorListener(open_bus("local:" + dir.file("bus")), 3), std::invalid_argument);
}

TEST(CanSensorListener, ASilentHeartbeatIsReportedAsAFaultUntilTheNextHeartbeat) {
  TempDir dir;
  LocalHub hub(dir.file("bus"));
  rtm_test::ManualClock clock;
  SensorListener listener(open_bus("local:" + dir.file("bus")), kJoystickSensorNode, 50'000'000, clock);
  auto device = open_bus("local:" + dir.file("bus"));
  device->send(*encode_heartbeat(kJoystickSensorNode, NmtState::operational));
  device->send(*encode_sync(1));
  EXPECT_FALSE(listener.poll(200'000'000));  // no wrench, but the heartbeat was read
  EXPECT_EQ(listener.counters().syncs, 1u);
  EXPECT_EQ(listener.counters().heartbeats, 1u);
  clock.advance(50'000'000);
  EXPECT_EQ(listener.fault_kind(), FaultKind::none) << "silent for the timeout itself, not longer";
  clock.advance(1'000'000);
  EXPECT_EQ(listener.fault_kind(), FaultKind::heartbeat_lost);
  const Fault both = listener.fault();
  EXPECT_EQ(both.kind, FaultKind::heartbeat_lost);
  EXPECT_EQ(both.reason, "joystick sensor 0x11: no heartbeat for 51 ms (limit 50 ms)");
  // A heartbeat clears it: the only kind that goes by itself.
  device->send(*encode_heartbeat(kJoystickSensorNode, NmtState::operational));
  device->send(*encode_sync(2));
  EXPECT_FALSE(listener.poll(200'000'000));
  ASSERT_EQ(listener.counters().syncs, 2u) << "the heartbeat before that SYNC was read";
  EXPECT_EQ(listener.fault_kind(), FaultKind::none) << listener.fault().reason;
}

}  // namespace
}  // namespace rtm::can
