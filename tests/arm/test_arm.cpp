// SPDX-License-Identifier: Apache-2.0
// Pa10Arm with the real CANopen master over the user-space CAN bus, against seven fake drives
// written here at the protocol level (boot-up, heartbeats, SDO mode of operation, NMT, the
// CiA 402 state machine, TPDO after each SYNC). The master is stepped in lock-step.
#include "arm/pa10/arm.h"

#include "arm/can/bus.h"
#include "arm/can/cia402.h"
#include "arm/can/local_bus.h"
#include "arm/can/master.h"
#include "arm/can/protocol.h"
#include "rtm_test/allocation_counter.h"
#include "rtm_test/eventually.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <mutex>
#include <thread>

namespace rtm::pa10 {
namespace {

using namespace std::chrono_literals;
namespace can = rtm::can;
using can::FaultKind;

constexpr double kPeriod_s = 0.002;

JointVector general_pose() {
  JointVector q;
  q << 0.3, 0.5, -0.4, 1.3, 0.6, 0.9, -0.5;
  return q;
}

std::string unique_hub_path() {
  static std::atomic<int> counter{0};
  return (std::filesystem::path(testing::TempDir()) /
          ("pa10_arm_" + std::to_string(::getpid()) + "_" + std::to_string(counter++) + ".bus"))
      .string();
}

// Seven PA10 drives on one bus endpoint. Positions integrate the commanded velocity over
// each SYNC period while the drive is in operation enabled.
class FakeDrives {
 public:
  FakeDrives(const std::string& hub_path, const JointVector& q0_rad)
      : bus_(can::open_local(hub_path)), q_rad_(q0_rad) {
    nmt_.fill(can::NmtState::pre_operational);  // after the boot-up message
    thread_ = std::thread([this] { run(); });
  }
  ~FakeDrives() {
    stop_ = true;
    thread_.join();
  }

  // On the next SYNC the drive goes to fault and sends this EMCY.
  void inject_fault(int joint, std::uint16_t emcy_code) {
    std::lock_guard lock(mutex_);
    pending_fault_joint_ = joint;
    pending_fault_code_ = emcy_code;
  }
  void silence_heartbeat(int joint) { heartbeat_silenced_[joint] = true; }

  double last_target_rad_s(int joint) const {
    std::lock_guard lock(mutex_);
    return last_target_rad_s_[joint];
  }
  JointVector positions() const {
    std::lock_guard lock(mutex_);
    return q_rad_;
  }
  std::uint64_t syncs() const { return syncs_.load(); }

 private:
  void send(const can::Result<can_frame>& frame) {
    if (frame) bus_->send(frame.value());
  }

  void send_heartbeats(bool boot_up) {
    for (int j = 0; j < can::kDriveCount; ++j) {
      if (heartbeat_silenced_[j]) continue;
      send(can::encode_heartbeat(can::drive_node(j), boot_up ? can::NmtState::boot_up : nmt_[j]));
    }
  }

  void on_nmt(const can_frame& frame) {
    const auto nmt = can::decode_nmt(frame);
    if (!nmt) return;
    for (int j = 0; j < can::kDriveCount; ++j) {
      if (nmt->node != can::kNmtAllNodes && nmt->node != can::drive_node(j)) continue;
      switch (nmt->command) {
        case can::NmtCommand::start: nmt_[j] = can::NmtState::operational; break;
        case can::NmtCommand::stop: nmt_[j] = can::NmtState::stopped; break;
        default: nmt_[j] = can::NmtState::pre_operational; break;
      }
    }
  }

  void on_sdo(const can_frame& frame) {
    const auto request = can::decode_sdo_request(frame);
    if (!request || !can::is_drive_node(request->node)) return;
    const int j = can::joint_index_of(request->node);
    can::SdoResponse response{request->node, can::SdoResponseKind::abort, request->index,
                              request->subindex, can::sdo::kAbortNoObject, 0};
    if (request->kind == can::SdoRequestKind::download &&
        request->index == can::object::kModesOfOperation) {
      mode_[j] = static_cast<std::int8_t>(request->data);
      response.kind = can::SdoResponseKind::download_ack;
      response.data = 0;
    } else if (request->kind == can::SdoRequestKind::upload &&
               request->index == can::object::kModesOfOperationDisplay) {
      response.kind = can::SdoResponseKind::upload_data;
      response.data = static_cast<std::uint8_t>(mode_[j]);
      response.data_size = 1;
    }
    send(can::encode_sdo_response(response));
  }

  void on_sync() {
    ++syncs_;
    std::lock_guard lock(mutex_);
    if (pending_fault_joint_ >= 0) {
      drives_[pending_fault_joint_].raise_fault();
      send(can::encode_emcy(can::drive_node(pending_fault_joint_), pending_fault_code_, 0x01));
      pending_fault_joint_ = -1;
    }
    for (int j = 0; j < can::kDriveCount; ++j) {
      if (nmt_[j] != can::NmtState::operational) continue;
      if (has_command_[j]) drives_[j].apply_controlword(command_[j].controlword);
      const double velocity_rad_s =
          drives_[j].follows_target_velocity() ? command_[j].target_velocity_rad_s : 0.0;
      last_target_rad_s_[j] = has_command_[j] ? command_[j].target_velocity_rad_s : 0.0;
      q_rad_[j] += velocity_rad_s * kPeriod_s;
      send(can::encode_drive_feedback(
          {can::drive_node(j), drives_[j].statusword(), q_rad_[j], velocity_rad_s}));
    }
  }

  void run() {
    send_heartbeats(/*boot_up=*/true);
    auto next_heartbeat = std::chrono::steady_clock::now() + 100ms;
    while (!stop_) {
      if (std::chrono::steady_clock::now() >= next_heartbeat) {
        send_heartbeats(false);
        next_heartbeat += 100ms;
      }
      can_frame frame{};
      try {
        if (!bus_->receive(frame, 1'000'000)) continue;
      } catch (const can::BusError&) {
        return;  // the hub went away: the test is ending
      }
      const can::Classified c = can::classify(frame);
      switch (c.type) {
        case can::FrameType::nmt: on_nmt(frame); break;
        case can::FrameType::sdo_request: on_sdo(frame); break;
        case can::FrameType::sync: on_sync(); break;
        case can::FrameType::drive_command: {
          const auto command = can::decode_drive_command(frame);
          if (!command) break;
          const int j = can::joint_index_of(command->drive);
          std::lock_guard lock(mutex_);
          command_[j] = *command;
          has_command_[j] = true;
          break;
        }
        default: break;
      }
    }
  }

  std::unique_ptr<can::Bus> bus_;
  std::atomic<bool> stop_{false};
  mutable std::mutex mutex_;
  std::array<can::Cia402Drive, can::kDriveCount> drives_{};
  std::array<can::NmtState, can::kDriveCount> nmt_{};
  std::array<std::int8_t, can::kDriveCount> mode_{};
  std::array<can::DriveCommand, can::kDriveCount> command_{};
  std::array<bool, can::kDriveCount> has_command_{};
  std::array<double, can::kDriveCount> last_target_rad_s_{};
  std::array<std::atomic<bool>, can::kDriveCount> heartbeat_silenced_{};
  JointVector q_rad_;
  int pending_fault_joint_ = -1;
  std::uint16_t pending_fault_code_ = 0;
  std::atomic<std::uint64_t> syncs_{0};
  std::thread thread_;
};

can::MasterConfig lock_step_config() {
  can::MasterConfig config;
  config.sensors.clear();  // the fake has drives only
  return config;
}

// Hub, fake drives, master and arm, declared so that they are torn down in reverse: the arm,
// then the master (its shutdown frames still reach the hub), then the drives, then the hub.
struct Rig {
  explicit Rig(const JointVector& q0 = general_pose())
      : hub(unique_hub_path()),
        drives(hub.path(), q0),
        master(can::open_local(hub.path()), nullptr, lock_step_config()),
        arm(master) {}

  void start_master() {
    master.start();
    master.step();  // first feedback after enabling
  }
  // Steps until `done()` or max_cycles; true when done.
  template <class Done>
  bool step_until(Done done, int max_cycles) {
    for (int i = 0; i < max_cycles; ++i) {
      if (done()) return true;
      master.step();
    }
    return done();
  }

  can::LocalHub hub;
  FakeDrives drives;
  can::Pa10Master master;
  Pa10Arm arm;
};

std::array<float, 6> small_twist() { return {0.01f, -0.02f, 0.015f, 0.0f, 0.05f, 0.0f}; }

TEST(Pa10Arm, ReportsNotEnabledBeforeTheMasterHasStarted) {
  Rig rig;
  EXPECT_EQ(rig.arm.order_velocity(small_twist()), FaultKind::not_enabled);
  EXPECT_EQ(rig.arm.fault(), FaultKind::not_enabled);
  EXPECT_NE(rig.arm.fault_reason().find("not enabled"), std::string::npos) << rig.arm.fault_reason();
  // Not latched: once the master is up, the arm moves without a reset.
  rig.start_master();
  EXPECT_EQ(rig.arm.order_velocity(small_twist()), FaultKind::none) << rig.arm.fault_reason();
  EXPECT_EQ(rig.arm.fault(), FaultKind::none);
  EXPECT_EQ(rig.arm.fault_reason(), "");
}

TEST(Pa10Arm, TheMeasuredToolPoseIsUnknownBeforeTheFirstFeedbackThenTheFkOfTheDrivesPositions) {
  Rig rig;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() << 7, 7, 7;
  EXPECT_FALSE(rig.arm.measured_tool_pose(pose)) << "no feedback yet";
  EXPECT_EQ(pose.translation(), Eigen::Vector3d(7, 7, 7)) << "left untouched";
  rig.start_master();
  ASSERT_TRUE(rig.arm.measured_tool_pose(pose));
  Kinematics model = Kinematics::pa10();
  const Eigen::Isometry3d expected = model.tool_pose(rig.drives.positions());
  EXPECT_LT((pose.translation() - expected.translation()).norm(), 1e-5);  // 1 urad in the TPDOs
  EXPECT_LT((pose.linear() - expected.linear()).norm(), 1e-5);
}

TEST(Pa10Arm, OrderVelocityMovesTheToolAlongTheCommandedTwist) {
  Rig rig;
  rig.start_master();
  const Eigen::Isometry3d start = rig.arm.tool_pose();
  const std::array<float, 6> twist{0.02f, -0.01f, 0.015f, 0.0f, 0.0f, 0.0f};
  const int cycles = 100;
  for (int i = 0; i < cycles; ++i) {
    ASSERT_EQ(rig.arm.order_velocity(twist), FaultKind::none) << rig.arm.fault_reason();
    ASSERT_TRUE(rig.master.step());
  }
  // The drives got the IK's rates (to the protocol's 1 urad/s resolution).
  for (int j = 0; j < kJointCount; ++j)
    EXPECT_NEAR(rig.drives.last_target_rad_s(j), rig.arm.last_ik().qdot_rad_s[j], 1e-6) << j;
  EXPECT_DOUBLE_EQ(rig.arm.last_ik().twist_scale, 1.0);

  const Eigen::Isometry3d end = rig.arm.tool_pose();
  const Eigen::Vector3d moved_m = end.translation() - start.translation();
  // The first order is applied from the SYNC after it, so count whole periods loosely.
  const Eigen::Vector3d expected_m =
      Eigen::Vector3d(twist[0], twist[1], twist[2]) * (cycles - 1) * kPeriod_s;
  EXPECT_GT(moved_m.normalized().dot(expected_m.normalized()), 0.999) << moved_m.transpose();
  EXPECT_NEAR(moved_m.norm(), expected_m.norm(), 0.05 * expected_m.norm());
  EXPECT_LE(Eigen::AngleAxisd(end.linear() * start.linear().transpose()).angle(), 1e-3);
  // The arm reads back what the drives report.
  EXPECT_LE((rig.arm.joint_positions() - rig.drives.positions()).norm(), 1e-5);
}

TEST(Pa10Arm, TooFastATwistIsScaledAndTheDrivesStayWithinTheirVelocityLimits) {
  Rig rig;
  rig.start_master();
  const std::array<float, 6> fast{1.5f, -1.0f, 1.2f, 0.0f, 0.0f, 0.0f};  // m/s
  ASSERT_EQ(rig.arm.order_velocity(fast), FaultKind::none) << rig.arm.fault_reason();
  ASSERT_TRUE(rig.master.step());
  EXPECT_LT(rig.arm.last_ik().twist_scale, 1.0);
  const JointLimits& limits = rig.arm.kinematics().limits();
  for (int j = 0; j < kJointCount; ++j)
    EXPECT_LE(std::abs(rig.drives.last_target_rad_s(j)), limits.velocity_rad_s[j] + 1e-6) << j;
}

TEST(Pa10Arm, DriveFaultLatchesZeroVelocityWithTheReasonUntilReset) {
  Rig rig;
  rig.start_master();
  ASSERT_EQ(rig.arm.order_velocity(small_twist()), FaultKind::none);
  rig.master.step();
  const int e1 = 3;
  rig.drives.inject_fault(e1, can::emcy::kDeviceHardware);
  ASSERT_TRUE(rig.step_until([&] { return can::latched(rig.arm.order_velocity(small_twist())); }, 50));
  // The master's kind as it latched it: the drive's EMCY comes before its fault statusword.
  EXPECT_EQ(rig.arm.fault(), FaultKind::emergency);
  const std::string reason = rig.arm.fault_reason();
  EXPECT_NE(reason.find("emergency: drive 4 (E1): EMCY 0x5000"), std::string::npos) << reason;
  EXPECT_NE(reason.find("E1"), std::string::npos) << reason;

  // Latched: further orders are refused and every drive is commanded zero.
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(rig.arm.order_velocity(small_twist()), FaultKind::emergency);
    rig.master.step();
  }
  EXPECT_EQ(rig.arm.fault(), FaultKind::emergency);
  for (int j = 0; j < kJointCount; ++j) EXPECT_EQ(rig.drives.last_target_rad_s(j), 0.0) << j;

  rig.arm.reset();
  EXPECT_EQ(rig.arm.fault(), FaultKind::not_enabled);
  ASSERT_TRUE(rig.step_until([&] { return rig.arm.order_velocity(small_twist()) == FaultKind::none; }, 1000))
      << rig.arm.fault_reason();
  EXPECT_EQ(rig.arm.fault(), FaultKind::none);
  rig.master.step();
  EXPECT_NE(rig.drives.last_target_rad_s(0), 0.0) << "motion resumes after the reset";
}

TEST(Pa10Arm, RpdoTimeoutOfADriveIsACommandLossThatResetClears) {
  Rig rig;
  rig.start_master();
  ASSERT_EQ(rig.arm.order_velocity(small_twist()), FaultKind::none);
  rig.master.step();
  rig.drives.inject_fault(5, can::emcy::kRpdoTimeout);
  ASSERT_TRUE(rig.step_until([&] { return can::latched(rig.arm.order_velocity(small_twist())); }, 50));
  EXPECT_EQ(rig.arm.fault(), FaultKind::command_loss);
  EXPECT_NE(rig.arm.fault_reason().find("command_loss: drive 6 (W1): EMCY 0x8250"), std::string::npos)
      << rig.arm.fault_reason();
  rig.arm.reset();
  ASSERT_TRUE(rig.step_until([&] { return rig.arm.order_velocity(small_twist()) == FaultKind::none; }, 1000)) << rig.arm.fault_reason();
  EXPECT_EQ(rig.arm.fault(), FaultKind::none);
}

TEST(Pa10Arm, QuickStopBrakesTheDrivesUntilTheNextOrder) {
  Rig rig;
  rig.start_master();
  for (int i = 0; i < 3; ++i) {
    ASSERT_EQ(rig.arm.order_velocity(small_twist()), FaultKind::none) << rig.arm.fault_reason();
    rig.master.step();
  }
  ASSERT_EQ(rig.arm.quick_stop(), FaultKind::none) << rig.arm.fault_reason();
  ASSERT_TRUE(rig.step_until([&] { return rig.master.quick_stopped(); }, 10));
  const JointVector braked_rad = rig.drives.positions();
  for (int i = 0; i < 5; ++i) {
    ASSERT_EQ(rig.arm.quick_stop(), FaultKind::none) << rig.arm.fault_reason();
    rig.master.step();
  }
  EXPECT_EQ(rig.drives.positions(), braked_rad) << "the drives hold still";
  for (int j = 0; j < kJointCount; ++j)
    EXPECT_EQ(rig.arm.joint_velocities()[j], 0.0) << j;
  EXPECT_EQ(rig.arm.fault(), FaultKind::none) << rig.arm.fault_reason();

  ASSERT_EQ(rig.arm.order_velocity(small_twist()), FaultKind::none) << rig.arm.fault_reason();
  rig.master.step();
  rig.master.step();
  EXPECT_NE(rig.drives.positions(), braked_rad) << "motion resumes on the next order";
  EXPECT_FALSE(rig.master.quick_stopped());
}

TEST(Pa10Arm, HeartbeatLossLatchesAFaultNamingTheNode) {
  Rig rig;
  rig.start_master();
  const int w1 = 5;
  rig.drives.silence_heartbeat(w1);
  // The master's watch runs on real time (300 ms): step at about the real period until then.
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  bool faulted = false;
  while (!faulted && std::chrono::steady_clock::now() < deadline) {
    faulted = can::latched(rig.arm.order_velocity(small_twist()));
    rig.master.step();
    std::this_thread::sleep_for(2ms);
  }
  ASSERT_TRUE(faulted) << "no fault while drive 6 was silent";
  EXPECT_EQ(rig.arm.fault(), FaultKind::heartbeat_lost);
  EXPECT_NE(rig.arm.fault_reason().find("W1"), std::string::npos) << rig.arm.fault_reason();
  EXPECT_EQ(rig.arm.order_velocity(small_twist()), FaultKind::heartbeat_lost);
  rig.master.step();
  for (int j = 0; j < kJointCount; ++j) EXPECT_EQ(rig.drives.last_target_rad_s(j), 0.0) << j;
}

TEST(Pa10Arm, NanTwistLatchesIkFailureAndCommandsZeroUntilReset) {
  Rig rig;
  rig.start_master();
  ASSERT_EQ(rig.arm.order_velocity(small_twist()), FaultKind::none);
  rig.master.step();
  std::array<float, 6> bad = small_twist();
  bad[2] = std::nanf("");
  EXPECT_EQ(rig.arm.order_velocity(bad), FaultKind::ik_failed);
  EXPECT_EQ(rig.arm.fault(), FaultKind::ik_failed);
  EXPECT_NE(rig.arm.fault_reason().find("NaN"), std::string::npos) << rig.arm.fault_reason();
  rig.master.step();
  for (int j = 0; j < kJointCount; ++j) EXPECT_EQ(rig.drives.last_target_rad_s(j), 0.0) << j;
  // A good twist does not clear the fault by itself.
  EXPECT_EQ(rig.arm.order_velocity(small_twist()), FaultKind::ik_failed);
  EXPECT_EQ(rig.arm.fault(), FaultKind::ik_failed);

  rig.arm.reset();
  ASSERT_TRUE(rig.step_until([&] { return rig.arm.order_velocity(small_twist()) == FaultKind::none; }, 1000))
      << rig.arm.fault_reason();
  EXPECT_EQ(rig.arm.fault(), FaultKind::none);
}

// The same arm with the master on its own 2 ms SYNC thread: orders come from this thread at
// any time, the master picks up the latest at each cycle.
TEST(Pa10Arm, WorksWithTheMastersOwnPeriodicThread) {
  Rig rig;
  rig.master.start();
  rig.master.run_periodic();
  rtm_test::eventually([&] { return rig.arm.joint_positions() != JointVector::Zero(); });  // the first feedback
  const auto deadline = std::chrono::steady_clock::now() + 20s;
  const Eigen::Isometry3d start = rig.arm.tool_pose();
  const std::array<float, 6> twist{0.0f, 0.03f, -0.02f, 0.0f, 0.0f, 0.0f};
  const double wanted_m = 0.003;
  Eigen::Vector3d moved_m = Eigen::Vector3d::Zero();
  while (moved_m.norm() < wanted_m && std::chrono::steady_clock::now() < deadline) {
    ASSERT_EQ(rig.arm.order_velocity(twist), FaultKind::none) << rig.arm.fault_reason();
    std::this_thread::sleep_for(2ms);
    moved_m = rig.arm.tool_pose().translation() - start.translation();
  }
  rig.arm.stop();
  ASSERT_GE(moved_m.norm(), wanted_m) << "the tool did not move";
  const Eigen::Vector3d direction = Eigen::Vector3d(twist[0], twist[1], twist[2]).normalized();
  EXPECT_GT(moved_m.normalized().dot(direction), 0.999) << moved_m.transpose();

  // A drive fault reaches the arm through the master's thread too.
  rig.drives.inject_fault(0, rtm::can::emcy::kDeviceHardware);
  bool faulted = false;
  while (!faulted && std::chrono::steady_clock::now() < deadline) {
    faulted = can::latched(rig.arm.order_velocity(twist));
    std::this_thread::sleep_for(2ms);
  }
  EXPECT_TRUE(faulted) << rig.arm.fault_reason();
  EXPECT_TRUE(rig.arm.fault() == FaultKind::emergency || rig.arm.fault() == FaultKind::drive_fault)
      << rig.arm.fault_reason();
  EXPECT_NE(rig.arm.fault_reason().find("S1"), std::string::npos) << rig.arm.fault_reason();
  rig.master.stop();
}

TEST(Pa10Arm, OrderVelocityAndTheMeasuredToolPoseAllocateNothing) {
  Rig rig;
  rig.start_master();
  ASSERT_EQ(rig.arm.order_velocity(small_twist()), FaultKind::none);
  rig.master.step();
  std::uint64_t allocations = 0;
  Eigen::Isometry3d pose;
  for (int i = 0; i < 50; ++i) {
    const auto before = rtm_test::allocations_on_this_thread();
    const FaultKind state = rig.arm.order_velocity(small_twist());
    const bool measured = rig.arm.measured_tool_pose(pose);
    const std::array<double, 6> vector = pose_vector(pose);
    allocations += rtm_test::allocations_on_this_thread() - before;
    ASSERT_TRUE(measured);
    ASSERT_TRUE(std::isfinite(vector[5]));
    ASSERT_EQ(state, FaultKind::none) << rig.arm.fault_reason();
    rig.master.step();
  }
  EXPECT_EQ(allocations, 0u);
}

TEST(Pa10Arm, MalformedUrdfPathIsAClearError) {
  can::LocalHub hub(unique_hub_path());
  can::Pa10Master master(can::open_local(hub.path()), nullptr, lock_step_config());
  try {
    Pa10Arm arm("/nonexistent/pa10.urdf", master);
    FAIL() << "expected ModelError";
  } catch (const ModelError& error) {
    EXPECT_NE(std::string(error.what()).find("/nonexistent/pa10.urdf"), std::string::npos);
  }
}

}  // namespace
}  // namespace rtm::pa10
