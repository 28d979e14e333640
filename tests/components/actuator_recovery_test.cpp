// SPDX-License-Identifier: Apache-2.0
// The actuator's fault policy against the real arm library and CANopen master, with the PA10's
// CAN nodes as pa10-sim emulates them (on a kinematic plant) on the user-space bus, in lock-step
// (one actuator cycle, then one SYNC): a drive's RPDO timeout (EMCY 0x8250, a communication
// fault) is reset and the arm moves again on the next command, counted once; a hardware fault
// still puts the component in error; a silent wrist sensor stops the drives, is retried, and
// the arm moves again once the node is heard, within a budget.
#include "components/actuator/actuator.h"

#include "arm/can/local_bus.h"
#include "component_test_support.h"
#include "rtm_test/can/emulated_pa10.h"
#include "rtm_test/can/test_paths.h"

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
