// SPDX-License-Identifier: Apache-2.0
// The actuator's fault policy against the real arm library and CANopen master, with the PA10's
// CAN nodes as pa10-sim emulates them (on a kinematic plant) on the user-space bus, in lock-step
// (one actuator cycle, then one SYNC): a drive's RPDO timeout (EMCY 0x8250, a communication
// fault) is reset and the arm moves again on the next command, counted once; a hardware fault
// still puts the component in error; a silent wrist sensor stops the drives, is retried, and
// the arm moves again once the node is heard, within a budget. And the measured pose the
// actuator writes to its "pose" port, against the same emulated drives.
#include "components/actuator/actuator.h"

#include "arm/can/local_bus.h"
#include "arm/pa10/kinematics.h"
#include "component_test_support.h"
#include "rtm_test/allocation_counter.h"
#include "rtm_test/can/emulated_pa10.h"
#include "rtm_test/can/test_paths.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <memory>
#include <optional>

namespace {

using namespace std::chrono_literals;
using comp_test::cycle;
using comp_test::float6;
namespace pc = rtm::can;

struct LockStepActuator {
  pc::testing::TempDir dir;
  pc::LocalHub hub{dir.file("bus")};
  std::unique_ptr<pc::testing::EmulatedPa10> nodes;
  rtm::pa10::ArmHardware* hardware = nullptr;
  std::unique_ptr<rtm::comp::Actuator> actuator;
  std::uint64_t n = 0;

  explicit LockStepActuator(rtm::comp::ActuatorParams params = {}, std::int64_t step_timeout_ns = 2'000'000'000) {
    rtm::pa10::ArmHardware::Options options;
    options.bus = "local:" + dir.file("bus");
    options.run_master_thread = false;
    options.step_timeout_ns = step_timeout_ns;
    // The master finds the nodes by their heartbeats, so the nodes may be up first.
    nodes = std::make_unique<pc::testing::EmulatedPa10>(options.bus);
    auto arm = std::make_unique<rtm::pa10::ArmHardware>(options);
    hardware = arm.get();
    actuator = std::make_unique<rtm::comp::Actuator>("actuator0", std::move(arm), params);
    actuator->on_start();
  }
  ~LockStepActuator() {
    actuator.reset();  // master shutdown frames while the nodes still listen
    nodes.reset();
  }

  // One cycle with a new command (or none), then the SYNC that carries it.
  void step(std::optional<std::array<float, 6>> command = std::nullopt) {
    if (command) actuator->command_in().deliver(float6(*command));
    actuator->on_cycle(cycle(n++));
    hardware->master().step();
  }
  bool moving() const {
    for (int j = 0; j < pc::kDriveCount; ++j) {
      if (nodes->latched_velocity_rad_s(pc::drive_node(j)) != 0.0) return true;
    }
    return false;
  }
};

constexpr std::array<float, 6> kForward{0.01f, 0, 0, 0, 0, 0};

TEST(ActuatorRecovery, DriveRpdoTimeoutIsResetAndTheArmMovesAgainOnTheNextCommand) {
  LockStepActuator t;
  for (int i = 0; i < 5; ++i) t.step(kForward);
  ASSERT_TRUE(t.moving());

  // Its commands are lost for 3 SYNCs (as after a host stall of the master): the drive's own
  // command-loss guard brakes it and sends EMCY 0x8250.
  t.nodes->lose_next_rpdos(pc::drive_node(3), 3);
  // The master sees the EMCY; the actuator resets instead of failing.
  for (int i = 0; i < 5; ++i) ASSERT_NO_THROW(t.step(kForward));
  EXPECT_EQ(t.actuator->counters().command_loss_recoveries, 1u);

  // Back in operation enabled, and moving with the commands that keep coming.
  for (int i = 0; i < 200 && !(t.moving() && t.hardware->master().enabled()); ++i) ASSERT_NO_THROW(t.step(kForward));
  EXPECT_TRUE(t.hardware->master().enabled()) << t.hardware->master().fault().reason;
  EXPECT_EQ(t.nodes->drive_state(pc::drive_node(3)), pc::DriveState::operation_enabled);
  EXPECT_TRUE(t.moving());
  EXPECT_EQ(t.actuator->counters().command_loss_recoveries, 1u) << "one event, counted once";
}

TEST(ActuatorRecovery, ADriveHardwareFaultStillPutsTheActuatorInError) {
  LockStepActuator t;
  for (int i = 0; i < 5; ++i) t.step(kForward);
  t.nodes->inject_fault(pc::drive_node(2));
  bool failed = false;
  for (int i = 0; i < 50 && !failed; ++i) {
    try {
      t.step(kForward);
    } catch (const std::runtime_error& e) {
      failed = true;
      EXPECT_NE(std::string(e.what()).find("drive 3 (S3)"), std::string::npos) << e.what();
    }
  }
  EXPECT_TRUE(failed) << "a hardware EMCY must latch an error, not be reset automatically";
  EXPECT_EQ(t.actuator->counters().command_loss_recoveries, 0u);
}

// The wrist sensor's cable pulled (no TPDO, no heartbeat) and plugged back in. Heartbeats are
// timed on the wall clock (300 ms limit), so the loops wait for conditions, with deadlines.
constexpr std::int64_t kSilentSensorStepNs = 5'000'000;  // a SYNC waits this long for the silent node

TEST(ActuatorRecovery, ASilentWristSensorStopsTheDrivesIsRetriedAndTheArmMovesAgainWhenItIsHeard) {
  LockStepActuator t({}, kSilentSensorStepNs);
  for (int i = 0; i < 5; ++i) t.step(kForward);
  ASSERT_TRUE(t.moving());

  t.nodes->set_connected(pc::kWristSensorNode, false);
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (t.actuator->counters().sensor_heartbeat_losses == 0 && std::chrono::steady_clock::now() < deadline)
    ASSERT_NO_THROW(t.step(kForward));
  ASSERT_EQ(t.actuator->counters().sensor_heartbeat_losses, 1u) << "the loss was never seen";
  for (int i = 0; i < 3; ++i) ASSERT_NO_THROW(t.step(kForward));
  EXPECT_FALSE(t.moving()) << "the drives stop while the sensor is silent";
  // Retries fail while the node stays silent, and are counted.
  for (std::uint32_t i = 0; i < 2 * rtm::comp::ActuatorParams::kSensorRetryPeriods; ++i)
    ASSERT_NO_THROW(t.step(kForward));
  EXPECT_GE(t.actuator->counters().sensor_reset_attempts, 2u);
  EXPECT_FALSE(t.moving());
  EXPECT_EQ(t.actuator->counters().sensor_heartbeat_recoveries, 0u);

  t.nodes->set_connected(pc::kWristSensorNode, true);
  const auto back_deadline = std::chrono::steady_clock::now() + 10s;
  while (t.actuator->counters().sensor_heartbeat_recoveries == 0 && std::chrono::steady_clock::now() < back_deadline)
    ASSERT_NO_THROW(t.step(kForward));
  ASSERT_EQ(t.actuator->counters().sensor_heartbeat_recoveries, 1u) << t.hardware->master().fault().reason;
  for (int i = 0; i < 200 && !(t.moving() && t.hardware->master().enabled()); ++i) ASSERT_NO_THROW(t.step(kForward));
  EXPECT_TRUE(t.moving()) << "moving again with the commands that keep coming";
  EXPECT_EQ(t.actuator->counters().sensor_heartbeat_losses, 1u) << "one event, counted once";
}

TEST(ActuatorRecovery, AWristSensorSilentBeyondTheBudgetPutsTheActuatorInErrorNamingIt) {
  rtm::comp::ActuatorParams params;
  params.sensor_recovery_periods = 60;
  LockStepActuator t(params, kSilentSensorStepNs);
  for (int i = 0; i < 5; ++i) t.step(kForward);
  t.nodes->set_connected(pc::kWristSensorNode, false);
  std::string error;
  const auto deadline = std::chrono::steady_clock::now() + 20s;
  while (error.empty() && std::chrono::steady_clock::now() < deadline) {
    try {
      t.step(kForward);
    } catch (const std::runtime_error& e) {
      error = e.what();
    }
  }
  ASSERT_FALSE(error.empty()) << "the actuator waited for ever";
  EXPECT_NE(error.find("wrist sensor 0x10"), std::string::npos) << error;
  EXPECT_NE(error.find("not heard again within 60 cycles"), std::string::npos) << error;
  EXPECT_EQ(t.actuator->counters().sensor_heartbeat_losses, 1u);
  EXPECT_EQ(t.actuator->counters().sensor_heartbeat_recoveries, 0u);
  EXPECT_FALSE(t.moving());
}

// ---------------------------------------------------------------- the measured pose
// The pose port against the drives pa10-sim emulates: the arm moved by known twists, the pose
// compared with what it must be, computed here apart from the actuator (the model's own forward
// kinematics of the joint positions, the rotation vector turned back into a matrix).

constexpr std::array<float, 6> kStill{};
constexpr double kPeriod_s = 0.002;

std::array<double, 6> latest_pose(const LockStepActuator& t) {
  RTM::TimedFloat6 d{};
  EXPECT_TRUE(t.actuator->pose_out().latest(d)) << "no pose written yet";
  std::array<double, 6> out{};
  for (CORBA::ULong i = 0; i < 6; ++i) out[i] = d.val[i];
  return out;
}

Eigen::Vector3d position_of(const std::array<double, 6>& pose) { return {pose[0], pose[1], pose[2]}; }

Eigen::Matrix3d rotation_of(const std::array<double, 6>& pose) {
  const Eigen::Vector3d r(pose[3], pose[4], pose[5]);
  if (r.norm() == 0.0) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(r.norm(), r.normalized()).toRotationMatrix();
}

rtm::pa10::JointVector to_joints(const std::array<double, pc::kDriveCount>& positions) {
  rtm::pa10::JointVector q;
  for (int j = 0; j < rtm::pa10::kJointCount; ++j) q[j] = positions[static_cast<std::size_t>(j)];
  return q;
}

// Zero commands until the drives have answered, the pose is written and two cycles in a row
// leave it where it was (the commands before have all been carried out); the pose then, none
// when that does not happen within 200 cycles.
std::optional<std::array<double, 6>> pose_at_rest(LockStepActuator& t) {
  std::optional<std::array<double, 6>> last;
  for (int i = 0; i < 200; ++i) {
    t.step(kStill);
    if (t.actuator->pose_out().counters_snapshot().written == 0) continue;
    const std::array<double, 6> now = latest_pose(t);
    if (last == now && t.hardware->master().enabled() && !t.moving()) return now;
    last = now;
  }
  return std::nullopt;
}

constexpr const char* kNoRest = "the arm did not come to rest with its pose written within 200 cycles";

TEST(ActuatorPoseOnTheDrives, MovingAlongXForNCyclesMovesThePosesXByTheTwistTimesTheTime) {
  LockStepActuator t;
  const std::optional<std::array<double, 6>> start = pose_at_rest(t);
  ASSERT_TRUE(start) << kNoRest;
  constexpr int kCycles = 250;
  constexpr float kVx = 0.01f;  // m/s: 250 cycles of 2 ms are 5 mm
  for (int i = 0; i < kCycles; ++i) t.step(std::array<float, 6>{kVx, 0, 0, 0, 0, 0});
  const std::optional<std::array<double, 6>> end = pose_at_rest(t);
  ASSERT_TRUE(end) << kNoRest;
  const double expected_m = kVx * kCycles * kPeriod_s;
  const Eigen::Vector3d moved = position_of(*end) - position_of(*start);
  EXPECT_NEAR(moved.x(), expected_m, 0.02 * expected_m) << moved.transpose();
  EXPECT_NEAR(moved.y(), 0.0, 0.02 * expected_m) << moved.transpose();
  EXPECT_NEAR(moved.z(), 0.0, 0.02 * expected_m) << moved.transpose();
  const Eigen::AngleAxisd turned(rotation_of(*start).transpose() * rotation_of(*end));
  EXPECT_LT(turned.angle(), 1e-3) << "a pure translation turned the tool";
}

TEST(ActuatorPoseOnTheDrives, ThePoseIsTheForwardKinematicsOfTheJointPositionsTheDrivesReported) {
  LockStepActuator t;
  ASSERT_TRUE(pose_at_rest(t)) << kNoRest;
  rtm::pa10::Kinematics model = rtm::pa10::Kinematics::pa10();
  // Translate and turn at once, so that the orientation is far from the identity.
  const std::array<float, 6> twist{0.02f, -0.01f, 0.015f, 0.2f, -0.1f, 0.3f};
  int compared = 0;
  for (int i = 0; i < 400; ++i) {
    // What the cycle reads: the master's state does not change until its next step.
    const rtm::can::JointState state = t.hardware->master().joint_state();
    const std::uint64_t written = t.actuator->pose_out().counters_snapshot().written;
    t.step(twist);
    ASSERT_EQ(t.actuator->pose_out().counters_snapshot().written, written + 1) << "cycle " << i;
    if (i % 50 != 49) continue;
    const Eigen::Isometry3d expected = model.tool_pose(to_joints(state.position_rad));
    const std::array<double, 6> pose = latest_pose(t);
    // The port carries floats: about 1e-7 of the values.
    EXPECT_LT((position_of(pose) - expected.translation()).norm(), 1e-6) << "cycle " << i;
    EXPECT_LT((rotation_of(pose) - expected.linear()).norm(), 1e-5) << "cycle " << i;
    ++compared;
  }
  EXPECT_EQ(compared, 8);
  const std::array<double, 6> moving_pose = latest_pose(t);
  EXPECT_GT(Eigen::Vector3d(moving_pose[3], moving_pose[4], moving_pose[5]).norm(), 0.05)
      << "the tool did not turn: the rotation was not tested";

  // At rest, against the positions the emulated drives hold themselves (their TPDOs carry
  // them in 1 µrad steps).
  const std::optional<std::array<double, 6>> rest = pose_at_rest(t);
  ASSERT_TRUE(rest) << kNoRest;
  rtm::pa10::JointVector q;
  for (int j = 0; j < rtm::pa10::kJointCount; ++j) q[j] = t.nodes->position_rad(pc::drive_node(j));
  const Eigen::Isometry3d expected = model.tool_pose(q);
  EXPECT_LT((position_of(*rest) - expected.translation()).norm(), 1e-5);
  EXPECT_LT((rotation_of(*rest) - expected.linear()).norm(), 1e-5);
}

TEST(ActuatorPoseOnTheDrives, ACycleWithThePoseAllocatesNothing) {
  LockStepActuator t;
  ASSERT_TRUE(pose_at_rest(t)) << kNoRest;
  const std::array<float, 6> twist{0.01f, 0, 0, 0, 0, 0.1f};
  for (int i = 0; i < 10; ++i) t.step(twist);  // warm up
  const std::uint64_t written = t.actuator->pose_out().counters_snapshot().written;
  std::uint64_t allocations = 0;
  for (std::uint64_t i = 0; i < 100; ++i) {
    t.actuator->command_in().deliver(float6(twist));  // the delivery is the writer's, not the cycle's
    const std::uint64_t before = rtm_test::allocations_on_this_thread();
    t.actuator->on_cycle(cycle(t.n++));
    allocations += rtm_test::allocations_on_this_thread() - before;
    t.hardware->master().step();
  }
  EXPECT_EQ(t.actuator->pose_out().counters_snapshot().written, written + 100) << "a pose every cycle";
  EXPECT_EQ(allocations, 0u) << "allocations in 100 cycles that ordered the twist and wrote the pose";
}

TEST(ActuatorRecovery, ASensorRecoveryBudgetOfZeroIsRefusedNamingIt) {
  rtm::comp::ActuatorParams params;
  params.sensor_recovery_periods = 0;
  try {
    params.validate();
    FAIL() << "accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("sensor_recovery_periods"), std::string::npos) << e.what();
  }
}

}  // namespace
