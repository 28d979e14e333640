// SPDX-License-Identifier: Apache-2.0
// JointListener, the passive reader of the drives' joint feedback, against the PA10's CAN
// nodes as pa10-sim emulates them (driven by a Pa10Master in lock-step) on the user-space bus,
// and against hand-written frames: the state of each SYNC as the master sees it, complete
// only when every drive answered, the filters it opens a bus with, and a lost bus as fault().
#include "arm/can/joint_listener.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <map>
#include <thread>

#include "arm/can/local_bus.h"
#include "arm/can/master.h"
#include "rtm_test/can/master_rig.h"
#include "rtm_test/eventually.h"

namespace rtm::can::testing {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;

using rtm_test::eventually;

void expect_same_joints(const JointState& heard, const JointState& master) {
  EXPECT_EQ(heard.sync_counter, master.sync_counter);
  EXPECT_EQ(heard.complete, master.complete);
  for (std::size_t i = 0; i < kDriveCount; ++i) {
    EXPECT_EQ(heard.position_rad[i], master.position_rad[i]) << joint_name(static_cast<int>(i));
    EXPECT_EQ(heard.velocity_rad_s[i], master.velocity_rad_s[i]) << joint_name(static_cast<int>(i));
    EXPECT_EQ(heard.statusword[i], master.statusword[i]) << joint_name(static_cast<int>(i));
  }
}

TEST(CanJointListener, HearsTheJointStateTheMasterReadsOfTheSameSyncOnceEveryDriveAnswered) {
  MasterConfig config = test_config();
  config.target_expiry_periods = 0;  // one target for all 50 lock-step cycles
  Rig rig({}, config);
  JointListener listener(rig.spec);
  listener.start();
  EXPECT_FALSE(listener.latest().complete);
  EXPECT_EQ(listener.latest().sync_counter, 0) << "nothing heard yet";
  rig.master->start();
  rig.master->set_target_velocities({0.1, -0.2, 0.3, -0.4, 0.5, -0.6, 0.7});
  for (int i = 0; i < 50; ++i) ASSERT_TRUE(rig.master->step()) << "step " << i;

  const JointState master = rig.master->joint_state();
  ASSERT_TRUE(master.complete);
  ASSERT_TRUE(eventually([&] { return listener.latest().sync_counter == master.sync_counter; }));
  const JointState heard = listener.latest();
  expect_same_joints(heard, master);
  EXPECT_TRUE(heard.complete);
  EXPECT_NEAR(heard.position_rad[6], rig.nodes->position_rad(drive_node(6)), 1e-6) << "the plant moved W2";
  EXPECT_NE(heard.position_rad[6], 0.0);
  EXPECT_GE(heard.cycle, 50u);
  const JointListenerCounters counters = listener.counters();
  EXPECT_GE(counters.complete_syncs, 50u);
  EXPECT_EQ(counters.incomplete_syncs, 0u);
  EXPECT_EQ(counters.malformed_frames, 0u);
  EXPECT_FALSE(listener.fault().active()) << listener.fault().reason;
}

TEST(CanJointListener, StaysIncompleteWhileADriveIsSilentAndKeepsItsLastPosition) {
  MasterConfig config = test_config();
  config.step_timeout_ns = 200'000'000;  // each step waits this long for the silent drive
  Rig rig({}, config);
  JointListener listener(rig.spec);
  listener.start();
  rig.master->start();
  rig.master->set_target_velocities({0.2, 0, 0, 0.3, 0, 0, 0});
  for (int i = 0; i < 5; ++i) ASSERT_TRUE(rig.master->step());
  const std::uint8_t before_counter = rig.master->joint_state().sync_counter;
  ASSERT_TRUE(eventually([&] { return listener.latest().sync_counter == before_counter; }));
  const JointState before = listener.latest();
  ASSERT_TRUE(before.complete);
  const JointListenerCounters counters_before = listener.counters();

  rig.nodes->set_connected(drive_node(3), false);  // E1's cable pulled; it keeps moving
  std::map<std::uint8_t, JointState> master_by_sync;
  for (int i = 0; i < 5; ++i) {
    EXPECT_FALSE(rig.master->step()) << "E1 does not answer";
    master_by_sync[rig.master->joint_state().sync_counter] = rig.master->joint_state();
  }
  // A SYNC's window closes with the next SYNC: the last step's is still open.
  ASSERT_TRUE(eventually([&] { return listener.counters().incomplete_syncs == counters_before.incomplete_syncs + 4; }));
  const JointState heard = listener.latest();
  EXPECT_FALSE(heard.complete);
  ASSERT_TRUE(master_by_sync.contains(heard.sync_counter));
  expect_same_joints(heard, master_by_sync[heard.sync_counter]);
  EXPECT_EQ(heard.position_rad[3], before.position_rad[3]) << "E1's last report";
  EXPECT_GT(rig.nodes->position_rad(drive_node(3)) - before.position_rad[3], 1e-3) << "while E1 moved on";
  EXPECT_GT(heard.position_rad[0], before.position_rad[0]) << "S1 still reports";
  EXPECT_EQ(listener.counters().complete_syncs, counters_before.complete_syncs);

  rig.nodes->set_connected(drive_node(3), true);
  ASSERT_TRUE(rig.master->step()) << "E1 answers again";
  const JointState master = rig.master->joint_state();
  ASSERT_TRUE(eventually([&] { return listener.latest().sync_counter == master.sync_counter; }));
  expect_same_joints(listener.latest(), master);
  EXPECT_TRUE(listener.latest().complete);
}

TEST(CanJointListener, IgnoresFeedbackBeforeItsFirstSyncAndCountsMalformedFrames) {
  TempDir dir;
  LocalHub hub(dir.file("bus"));
  JointListener listener("local:" + dir.file("bus"));
  listener.start();
  auto device = open_bus("local:" + dir.file("bus"));
  auto send_all_feedback = [&](double position_rad) {
    for (int j = 0; j < kDriveCount; ++j)
      device->send(*encode_drive_feedback({drive_node(j), statusword::kOperationEnabled, position_rad + j, 0.5}));
  };
  send_all_feedback(-1.0);  // answers a SYNC the listener did not hear
  ASSERT_TRUE(eventually([&] { return listener.counters().feedback_frames == kDriveCount; }));
  EXPECT_EQ(listener.latest().sync_counter, 0);

  device->send(*encode_sync(17));
  can_frame short_feedback = *encode_drive_feedback({drive_node(2), statusword::kOperationEnabled, 9.0, 0.0});
  short_feedback.can_dlc = 4;
  device->send(short_feedback);
  send_all_feedback(1.0);
  ASSERT_TRUE(eventually([&] { return listener.latest().complete; }));
  const JointState heard = listener.latest();
  EXPECT_EQ(heard.sync_counter, 17);
  EXPECT_EQ(heard.cycle, 1u);
  for (int j = 0; j < kDriveCount; ++j) {
    const auto i = static_cast<std::size_t>(j);
    EXPECT_NEAR(heard.position_rad[i], 1.0 + j, 1e-6) << joint_name(j);
    EXPECT_NEAR(heard.velocity_rad_s[i], 0.5, 1e-3) << joint_name(j);
    EXPECT_EQ(heard.statusword[i], statusword::kOperationEnabled) << joint_name(j);
  }
  EXPECT_EQ(listener.counters().malformed_frames, 1u);
}

TEST(CanJointListener, OpensItsBusForSyncAndTheSevenDriveTpdo1sOnly) {
  const auto filters = JointListener::filters();
  EXPECT_TRUE(passes(*encode_sync(1), filters));
  for (int j = 0; j < kDriveCount; ++j)
    EXPECT_TRUE(passes(*encode_drive_feedback({drive_node(j), 0, 0.0, 0.0}), filters)) << joint_name(j);
  EXPECT_FALSE(passes(*encode_sensor_force({kWristSensorNode, {1, 2, 3}}), filters)) << "0x190: a sensor's TPDO1";
  EXPECT_FALSE(passes(*encode_emcy(drive_node(0), emcy::kDeviceHardware, 0x01), filters));
  EXPECT_FALSE(passes(*encode_heartbeat(drive_node(0), NmtState::operational), filters));
  EXPECT_FALSE(passes(*encode_drive_command({drive_node(0), controlword::kEnableOperation, 0.1}), filters));
}

TEST(CanJointListener, ALostBusIsReportedThroughFaultNamingTheBusNotThrown) {
  TempDir dir;
  auto hub = std::make_unique<LocalHub>(dir.file("bus"));
  const std::string spec = "local:" + dir.file("bus");
  JointListener listener(spec);
  listener.start();
  EXPECT_FALSE(listener.fault().active()) << listener.fault().reason;
  hub.reset();  // every endpoint sees the connection closed
  ASSERT_TRUE(eventually([&] { return listener.fault().active(); }));
  EXPECT_EQ(listener.fault_kind(), rtm::can::FaultKind::bus_error);
  EXPECT_EQ(listener.fault().kind, rtm::can::FaultKind::bus_error);
  EXPECT_THAT(listener.fault().reason, HasSubstr("joint listener"));
  EXPECT_THAT(listener.fault().reason, HasSubstr("CAN bus '" + spec + "'"));
  EXPECT_THAT(listener.fault().reason, HasSubstr("the hub closed the connection"));
  listener.stop();
  EXPECT_FALSE(listener.latest().complete);
}

TEST(CanJointListener, NamesTheSpecOfABusItCannotOpen) {
  TempDir dir;
  const std::string spec = "local:" + dir.file("no-hub");
  EXPECT_THAT([&] { JointListener listener(spec); },
              ::testing::ThrowsMessage<BusError>(HasSubstr(spec)));
}

}  // namespace
}  // namespace rtm::can::testing
