// The actuator's fault policy against the real arm library and CANopen master, with the PA10's
// CAN nodes as pa10-sim emulates them (on a kinematic plant) on the user-space bus, in lock-step
// (one actuator cycle, then one SYNC): a drive's RPDO timeout (EMCY 0x8250, a communication
// fault) is reset and the arm moves again on the next command, counted once; a hardware fault
// still puts the component in error.
#include "components/actuator/actuator.h"

#include "arm/can/local_bus.h"
#include "component_test_support.h"
#include "emulated_pa10.h"
#include "test_paths.h"

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
  rtm::comp::ArmHardware* hardware = nullptr;
  std::unique_ptr<rtm::comp::Actuator> actuator;
  std::uint64_t n = 0;

  LockStepActuator() {
    rtm::comp::ArmHardware::Options options;
    options.bus = "local:" + dir.file("bus");
    options.run_master_thread = false;
    // The master finds the nodes by their heartbeats, so the nodes may be up first.
    nodes = std::make_unique<pc::testing::EmulatedPa10>(options.bus);
    auto arm = std::make_unique<rtm::comp::ArmHardware>(options);
    hardware = arm.get();
    actuator = std::make_unique<rtm::comp::Actuator>("actuator0", std::move(arm), rtm::comp::ActuatorParams{});
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

}  // namespace
