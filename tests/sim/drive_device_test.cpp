// SPDX-License-Identifier: Apache-2.0
// The emulated drive, frame by frame: NMT, heartbeat, SDO, the CiA 402 state machine driven by
// RPDOs latched at SYNC, and the PA10 command-loss safety.
#include "sim/drive_device.h"

#include <gtest/gtest.h>

#include "arm/can/protocol.h"
#include "recording_sink.h"

namespace pc = rtm::can;
using rtm::sim::DriveConfig;
using rtm::sim::DriveDevice;
using rtm::sim::JointCommand;
using rtm::sim::JointState;
using rtm::sim::testing::RecordingSink;

namespace {

constexpr std::uint8_t kNode = 3;
constexpr std::int64_t kMs = 1'000'000;

class DriveDeviceTest : public ::testing::Test {
 protected:
  DriveDeviceTest() : drive_(DriveConfig{kNode, 100 * kMs, 3}) { drive_.power_on(0, out_); }

  void feed(const pc::Result<can_frame>& frame) {
    ASSERT_TRUE(frame.ok());
    drive_.on_frame(*frame, now_ns_, out_);
  }
  void sync() {
    sync_counter_ = pc::next_sync_counter(sync_counter_);
    now_ns_ += 2 * kMs;
    feed(pc::encode_sync(sync_counter_));
  }
  void rpdo(std::uint16_t controlword, double velocity_rad_s) {
    feed(pc::encode_drive_command({kNode, controlword, velocity_rad_s}));
  }
  pc::SdoResponse sdo(const pc::SdoRequest& request) {
    out_.clear();
    feed(pc::encode_sdo_request(request));
    const auto frames = out_.with_id(pc::cob::kSdoResponseBase + kNode);
    EXPECT_EQ(frames.size(), 1u);
    if (frames.empty()) return {};
    const auto response = pc::decode_sdo_response(frames.front());
    EXPECT_TRUE(response.ok());
    return response.ok() ? *response : pc::SdoResponse{};
  }
  // Pre-operational -> mode 9 -> operational -> operation enabled, one RPDO+SYNC per step.
  void enable() {
    sdo({kNode, pc::SdoRequestKind::download, pc::object::kModesOfOperation, 0, 9, 1});
    feed(pc::encode_nmt(pc::NmtCommand::start, 0));
    for (std::uint16_t cw : {pc::controlword::kShutdown, pc::controlword::kSwitchOn,
                             pc::controlword::kEnableOperation}) {
      rpdo(cw, 0);
      sync();
    }
    ASSERT_EQ(drive_.statusword(), pc::statusword::kOperationEnabled);
  }
  std::vector<pc::EmcyFrame> emcys() const {
    std::vector<pc::EmcyFrame> found;
    for (const auto& frame : out_.with_id(pc::cob::kEmcyBase + kNode))
      if (auto emcy = pc::decode_emcy(frame); emcy.ok()) found.push_back(*emcy);
    return found;
  }

  DriveDevice drive_;
  RecordingSink out_;
  std::int64_t now_ns_ = 0;
  std::uint8_t sync_counter_ = 0;
};

TEST_F(DriveDeviceTest, PowerOnSendsBootUpThenIsPreOperationalWithBrakeEngaged) {
  const auto bootups = out_.with_id(pc::cob::kHeartbeatBase + kNode);
  ASSERT_EQ(bootups.size(), 1u);
  EXPECT_EQ(pc::decode_heartbeat(bootups[0])->state, pc::NmtState::boot_up);
  EXPECT_EQ(drive_.nmt_state(), static_cast<std::uint8_t>(pc::NmtState::pre_operational));
  EXPECT_EQ(drive_.statusword(), pc::statusword::kSwitchOnDisabled);
  EXPECT_EQ(drive_.command().mode, JointCommand::Mode::hold);
}

TEST_F(DriveDeviceTest, HeartbeatEvery100msOfDeviceTimeCarriesNmtState) {
  out_.clear();
  drive_.tick(50 * kMs, out_);
  EXPECT_TRUE(out_.frames.empty());
  drive_.tick(100 * kMs, out_);
  drive_.tick(150 * kMs, out_);
  ASSERT_EQ(out_.frames.size(), 1u);
  EXPECT_EQ(pc::decode_heartbeat(out_.frames[0])->state, pc::NmtState::pre_operational);
  feed(pc::encode_nmt(pc::NmtCommand::start, kNode));
  drive_.tick(200 * kMs, out_);
  ASSERT_EQ(out_.frames.size(), 2u);
  EXPECT_EQ(pc::decode_heartbeat(out_.frames[1])->state, pc::NmtState::operational);
}

TEST_F(DriveDeviceTest, ModeOfOperationIsWrittenInPreOperationalAndReadBack) {
  const auto ack =
      sdo({kNode, pc::SdoRequestKind::download, pc::object::kModesOfOperation, 0, 9, 1});
  EXPECT_EQ(ack.kind, pc::SdoResponseKind::download_ack);
  const auto display =
      sdo({kNode, pc::SdoRequestKind::upload, pc::object::kModesOfOperationDisplay, 0, 0, 0});
  EXPECT_EQ(display.kind, pc::SdoResponseKind::upload_data);
  EXPECT_EQ(display.data, 9u);
  EXPECT_EQ(display.data_size, 1u);
  EXPECT_EQ(drive_.mode_of_operation(), 9);
}

TEST_F(DriveDeviceTest, SdoRefusesOtherModesWrongStateAndUnknownObjects) {
  auto bad_mode = sdo({kNode, pc::SdoRequestKind::download, pc::object::kModesOfOperation, 0, 3, 1});
  EXPECT_EQ(bad_mode.kind, pc::SdoResponseKind::abort);
  EXPECT_EQ(bad_mode.data, pc::sdo::kAbortValueRange);
  auto unknown = sdo({kNode, pc::SdoRequestKind::upload, 0x2345, 0, 0, 0});
  EXPECT_EQ(unknown.kind, pc::SdoResponseKind::abort);
  EXPECT_EQ(unknown.data, pc::sdo::kAbortNoObject);
  auto read_only = sdo({kNode, pc::SdoRequestKind::download, pc::object::kStatusword, 0, 0, 2});
  EXPECT_EQ(read_only.data, pc::sdo::kAbortReadOnly);
  feed(pc::encode_nmt(pc::NmtCommand::start, 0));
  auto operational =
      sdo({kNode, pc::SdoRequestKind::download, pc::object::kModesOfOperation, 0, 9, 1});
  EXPECT_EQ(operational.kind, pc::SdoResponseKind::abort);
  EXPECT_EQ(operational.data, pc::sdo::kAbortWrongState);
}

TEST_F(DriveDeviceTest, FramesForOtherNodesAreIgnored) {
  out_.clear();
  feed(pc::encode_nmt(pc::NmtCommand::start, kNode + 1));
  EXPECT_EQ(drive_.nmt_state(), static_cast<std::uint8_t>(pc::NmtState::pre_operational));
  feed(pc::encode_sdo_request({kNode + 1, pc::SdoRequestKind::upload, 0x6041, 0, 0, 0}));
  EXPECT_TRUE(out_.frames.empty());
}

TEST_F(DriveDeviceTest, StateMachineFollowsControlwordsLatchedAtSync) {
  sdo({kNode, pc::SdoRequestKind::download, pc::object::kModesOfOperation, 0, 9, 1});
  feed(pc::encode_nmt(pc::NmtCommand::start, 0));
  rpdo(pc::controlword::kShutdown, 0);
  EXPECT_EQ(drive_.statusword(), pc::statusword::kSwitchOnDisabled) << "applied before SYNC";
  sync();
  EXPECT_EQ(drive_.statusword(), pc::statusword::kReadyToSwitchOn);
  rpdo(pc::controlword::kSwitchOn, 0);
  sync();
  EXPECT_EQ(drive_.statusword(), pc::statusword::kSwitchedOn);
  rpdo(pc::controlword::kEnableOperation, 0.5);
  sync();
  EXPECT_EQ(drive_.statusword(), pc::statusword::kOperationEnabled);
  EXPECT_EQ(drive_.command().mode, JointCommand::Mode::velocity);
  EXPECT_DOUBLE_EQ(drive_.command().target_velocity_rad_s, 0.5);
}

TEST_F(DriveDeviceTest, TargetVelocityChangesOnlyAtTheNextSync) {
  enable();
  rpdo(pc::controlword::kEnableOperation, 0.25);
  EXPECT_DOUBLE_EQ(drive_.command().target_velocity_rad_s, 0.0);
  sync();
  EXPECT_DOUBLE_EQ(drive_.command().target_velocity_rad_s, 0.25);
}

TEST_F(DriveDeviceTest, Tpdo1AfterEachSyncReportsStatuswordPositionAndVelocity) {
  enable();
  out_.clear();
  rpdo(pc::controlword::kEnableOperation, 0.1);
  sync();
  drive_.send_tpdo(JointState{0.123456, -0.25}, out_);
  drive_.send_tpdo(JointState{9, 9}, out_);  // no second report without a new SYNC
  const auto tpdos = out_.with_id(pc::cob::kTpdo1Base + kNode);
  ASSERT_EQ(tpdos.size(), 1u);
  const auto feedback = pc::decode_drive_feedback(tpdos[0]);
  ASSERT_TRUE(feedback.ok());
  EXPECT_EQ(feedback->statusword, pc::statusword::kOperationEnabled);
  EXPECT_NEAR(feedback->position_rad, 0.123456, 1e-6);
  EXPECT_NEAR(feedback->velocity_rad_s, -0.25, 1e-3);
}

TEST_F(DriveDeviceTest, NoTpdoWhileNotOperational) {
  sync();
  drive_.send_tpdo(JointState{}, out_);
  EXPECT_TRUE(out_.with_id(pc::cob::kTpdo1Base + kNode).empty());
}

TEST_F(DriveDeviceTest, ThreeSyncsWithoutRpdoBrakeSendEmcy8250AndFault) {
  enable();
  rpdo(pc::controlword::kEnableOperation, 0.3);
  sync();
  out_.clear();
  sync();
  sync();
  EXPECT_EQ(drive_.command().mode, JointCommand::Mode::velocity) << "two SYNCs are tolerated";
  EXPECT_TRUE(emcys().empty());
  sync();
  EXPECT_TRUE(drive_.in_fault());
  EXPECT_EQ(drive_.command().mode, JointCommand::Mode::hold);
  EXPECT_EQ(drive_.command().target_velocity_rad_s, 0.0);
  const auto sent = emcys();
  ASSERT_EQ(sent.size(), 1u);
  EXPECT_EQ(sent[0].error_code, pc::emcy::kRpdoTimeout);
  drive_.send_tpdo(JointState{}, out_);
  const auto tpdo = pc::decode_drive_feedback(out_.with_id(pc::cob::kTpdo1Base + kNode).at(0));
  EXPECT_EQ(tpdo->statusword & pc::statusword::kStateMask, pc::statusword::kFault);
}

TEST_F(DriveDeviceTest, MasterSilentFor100msWithoutSyncsEitherBrakesTheDrive) {
  enable();
  const std::int64_t last_rpdo_ns = now_ns_;
  rpdo(pc::controlword::kEnableOperation, 0.3);
  sync();
  out_.clear();
  drive_.tick(last_rpdo_ns + 99 * kMs, out_);
  EXPECT_FALSE(drive_.in_fault()) << "a host stall of the master is tolerated";
  drive_.tick(last_rpdo_ns + 101 * kMs, out_);
  EXPECT_TRUE(drive_.in_fault());
  EXPECT_EQ(drive_.command().mode, JointCommand::Mode::hold);
  const auto sent = emcys();
  ASSERT_EQ(sent.size(), 1u);
  EXPECT_EQ(sent[0].error_code, pc::emcy::kRpdoTimeout);
}

TEST_F(DriveDeviceTest, OneRpdoPerSyncKeepsTheDriveEnabled) {
  enable();
  for (int i = 0; i < 50; ++i) {
    rpdo(pc::controlword::kEnableOperation, 0.1);
    sync();
  }
  EXPECT_FALSE(drive_.in_fault());
  EXPECT_TRUE(emcys().empty());
}

TEST_F(DriveDeviceTest, FaultStaysUntilResetEdgeThenEmcyZeroAndReEnable) {
  enable();
  sync();
  sync();
  sync();
  ASSERT_TRUE(drive_.in_fault());
  rpdo(pc::controlword::kEnableOperation, 0.3);
  sync();
  EXPECT_TRUE(drive_.in_fault()) << "commands are ignored in fault";
  out_.clear();
  rpdo(pc::controlword::kDisableVoltage, 0);
  sync();
  rpdo(pc::controlword::kFaultResetBit, 0);
  sync();
  EXPECT_FALSE(drive_.in_fault());
  EXPECT_EQ(drive_.statusword(), pc::statusword::kSwitchOnDisabled);
  const auto sent = emcys();
  ASSERT_EQ(sent.size(), 1u);
  EXPECT_EQ(sent[0].error_code, pc::emcy::kErrorReset);
  for (std::uint16_t cw : {pc::controlword::kShutdown, pc::controlword::kSwitchOn,
                           pc::controlword::kEnableOperation}) {
    rpdo(cw, 0);
    sync();
  }
  EXPECT_EQ(drive_.statusword(), pc::statusword::kOperationEnabled);
}

TEST_F(DriveDeviceTest, NmtStopBrakesAndSilencesPdos) {
  enable();
  feed(pc::encode_nmt(pc::NmtCommand::stop, 0));
  EXPECT_EQ(drive_.command().mode, JointCommand::Mode::hold);
  out_.clear();
  rpdo(pc::controlword::kEnableOperation, 0.2);
  sync();
  drive_.send_tpdo(JointState{}, out_);
  EXPECT_TRUE(out_.frames.empty());
  drive_.send_heartbeat(out_);
  ASSERT_EQ(out_.frames.size(), 1u);
  EXPECT_EQ(pc::decode_heartbeat(out_.frames[0])->state, pc::NmtState::stopped);
}

TEST_F(DriveDeviceTest, ResetNodeBootsAgain) {
  enable();
  out_.clear();
  feed(pc::encode_nmt(pc::NmtCommand::reset_node, kNode));
  ASSERT_EQ(out_.with_id(pc::cob::kHeartbeatBase + kNode).size(), 1u);
  EXPECT_EQ(drive_.nmt_state(), static_cast<std::uint8_t>(pc::NmtState::pre_operational));
  EXPECT_EQ(drive_.statusword(), pc::statusword::kSwitchOnDisabled);
  EXPECT_EQ(drive_.mode_of_operation(), 0);
}

// ---- fault injection ----------------------------------------------------------------------

TEST_F(DriveDeviceTest, InjectedFaultBrakesSendsItsEmcyAndIsClearedByAFaultReset) {
  enable();
  rpdo(pc::controlword::kEnableOperation, 0.3);
  sync();
  out_.clear();
  drive_.inject_fault(pc::emcy::kDeviceHardware, out_);
  EXPECT_TRUE(drive_.in_fault());
  EXPECT_EQ(drive_.command().mode, JointCommand::Mode::hold);
  EXPECT_EQ(drive_.target_velocity_rad_s(), 0.0);
  ASSERT_EQ(emcys().size(), 1u);
  EXPECT_EQ(emcys()[0].error_code, pc::emcy::kDeviceHardware);
  EXPECT_EQ(emcys()[0].error_register, 0x01);
  rpdo(pc::controlword::kFaultResetBit, 0);
  sync();
  EXPECT_FALSE(drive_.in_fault());
  EXPECT_EQ(emcys().back().error_code, pc::emcy::kErrorReset);
}

TEST_F(DriveDeviceTest, APersistentFaultSurvivesEveryFaultReset) {
  enable();
  drive_.set_fault_persistent(true);
  drive_.inject_fault(pc::emcy::kDeviceHardware, out_);
  out_.clear();
  for (int i = 0; i < 3; ++i) {
    rpdo(pc::controlword::kDisableVoltage, 0);
    sync();
    rpdo(pc::controlword::kFaultResetBit, 0);
    sync();
    EXPECT_TRUE(drive_.in_fault()) << "reset " << i;
  }
  EXPECT_TRUE(emcys().empty()) << "no error reset EMCY for a reset that did not take";
  drive_.set_fault_persistent(false);
  rpdo(pc::controlword::kDisableVoltage, 0);
  sync();
  rpdo(pc::controlword::kFaultResetBit, 0);
  sync();
  EXPECT_FALSE(drive_.in_fault()) << "repaired";
}

TEST_F(DriveDeviceTest, ADisconnectedDriveNeitherHearsNorSendsButItsGuardStillBrakesIt) {
  enable();
  rpdo(pc::controlword::kEnableOperation, 0.3);
  sync();
  out_.clear();
  drive_.set_connected(false);
  for (int i = 0; i < 3; ++i) {
    rpdo(pc::controlword::kEnableOperation, 0.3);
    sync();
    drive_.send_tpdo(JointState{}, out_);
  }
  drive_.send_heartbeat(out_);
  drive_.tick(now_ns_ + 200 * kMs, out_);
  EXPECT_TRUE(out_.frames.empty()) << "nothing reaches the bus";
  EXPECT_TRUE(drive_.in_fault()) << "no RPDO reached it: the command-loss guard braked it";
  EXPECT_EQ(drive_.command().mode, JointCommand::Mode::hold);
  drive_.set_connected(true);
  drive_.send_heartbeat(out_);
  EXPECT_EQ(out_.frames.size(), 1u);
}

TEST_F(DriveDeviceTest, ADisconnectedDriveDoesNotBoot) {
  DriveDevice drive(DriveConfig{kNode, 100 * kMs, 3});
  drive.set_connected(false);
  RecordingSink out;
  drive.power_on(0, out);
  drive.tick(500 * kMs, out);
  EXPECT_TRUE(out.frames.empty());
}

TEST_F(DriveDeviceTest, LostTpdosAreMissingFromTheBusAndTheNextOnesFlow) {
  enable();
  drive_.lose_next_tpdos(1);
  out_.clear();
  sync();
  drive_.send_tpdo(JointState{}, out_);
  EXPECT_TRUE(out_.with_id(pc::cob::kTpdo1Base + kNode).empty());
  rpdo(pc::controlword::kEnableOperation, 0);
  sync();
  drive_.send_tpdo(JointState{}, out_);
  EXPECT_EQ(out_.with_id(pc::cob::kTpdo1Base + kNode).size(), 1u);
}

TEST_F(DriveDeviceTest, RpdosLostForThreeSyncsTripTheCommandLossGuard) {
  enable();
  drive_.lose_next_rpdos(3);
  out_.clear();
  for (int i = 0; i < 3; ++i) {
    rpdo(pc::controlword::kEnableOperation, 0.1);
    sync();
  }
  EXPECT_TRUE(drive_.in_fault());
  ASSERT_EQ(emcys().size(), 1u);
  EXPECT_EQ(emcys()[0].error_code, pc::emcy::kRpdoTimeout);
}

TEST_F(DriveDeviceTest, AFirmwareWithoutCsvModeAbortsTheModeWrite) {
  DriveConfig config{kNode, 100 * kMs, 3};
  config.offers_csv_mode = false;
  DriveDevice drive(config);
  RecordingSink out;
  drive.power_on(0, out);
  out.clear();
  drive.on_frame(*pc::encode_sdo_request({kNode, pc::SdoRequestKind::download, pc::object::kModesOfOperation, 0, 9, 1}),
                 0, out);
  ASSERT_EQ(out.frames.size(), 1u);
  const auto response = pc::decode_sdo_response(out.frames[0]);
  ASSERT_TRUE(response.ok());
  EXPECT_EQ(response->kind, pc::SdoResponseKind::abort);
  EXPECT_EQ(response->data, pc::sdo::kAbortValueRange);
  EXPECT_EQ(drive.mode_of_operation(), 0);
}

TEST_F(DriveDeviceTest, TheLatchedControlwordAndSyncCounterAreObservable) {
  enable();
  EXPECT_EQ(drive_.controlword(), pc::controlword::kEnableOperation);
  EXPECT_EQ(drive_.last_sync_counter(), sync_counter_);
  rpdo(pc::controlword::kQuickStop, 0);
  EXPECT_EQ(drive_.controlword(), pc::controlword::kEnableOperation) << "latched at SYNC only";
  sync();
  EXPECT_EQ(drive_.controlword(), pc::controlword::kQuickStop);
}

}  // namespace
