// SPDX-License-Identifier: Apache-2.0
// The CiA 402 state machine on both sides: the device transitions, and the master's enabler
// reaching operation enabled against the device model, including fault and fault reset.
#include "arm/can/cia402.h"

#include <gtest/gtest.h>

namespace rtm::can {
namespace {

TEST(Cia402Statusword, DecodesEveryStateAndIgnoresUnrelatedBits) {
  EXPECT_EQ(state_from_statusword(0x0000), DriveState::not_ready_to_switch_on);
  EXPECT_EQ(state_from_statusword(0x0040), DriveState::switch_on_disabled);
  EXPECT_EQ(state_from_statusword(0x0060), DriveState::switch_on_disabled);  // bit 5 don't care
  EXPECT_EQ(state_from_statusword(0x0021), DriveState::ready_to_switch_on);
  EXPECT_EQ(state_from_statusword(0x0023), DriveState::switched_on);
  EXPECT_EQ(state_from_statusword(0x0027), DriveState::operation_enabled);
  EXPECT_EQ(state_from_statusword(0x0627), DriveState::operation_enabled);  // high bits ignored
  EXPECT_EQ(state_from_statusword(0x0007), DriveState::quick_stop_active);
  EXPECT_EQ(state_from_statusword(0x000F), DriveState::fault_reaction_active);
  EXPECT_EQ(state_from_statusword(0x0008), DriveState::fault);
  EXPECT_EQ(state_from_statusword(0x0028), DriveState::fault);
  EXPECT_EQ(state_from_statusword(0x0001), std::nullopt);
  EXPECT_EQ(state_from_statusword(0x0061), std::nullopt);
}

TEST(Cia402Statusword, StatuswordOfEachStateDecodesBackToIt) {
  for (auto s : {DriveState::not_ready_to_switch_on, DriveState::switch_on_disabled,
                 DriveState::ready_to_switch_on, DriveState::switched_on,
                 DriveState::operation_enabled, DriveState::quick_stop_active,
                 DriveState::fault_reaction_active, DriveState::fault}) {
    EXPECT_EQ(state_from_statusword(statusword_of(s)), s) << to_string(s);
  }
}

TEST(Cia402Controlword, DecodesTheCommandTable) {
  EXPECT_EQ(command_of(0x0000), DriveCommandWord::disable_voltage);
  EXPECT_EQ(command_of(0x0002), DriveCommandWord::quick_stop);
  EXPECT_EQ(command_of(0x0006), DriveCommandWord::shutdown);
  EXPECT_EQ(command_of(0x0007), DriveCommandWord::switch_on);
  EXPECT_EQ(command_of(0x000F), DriveCommandWord::enable_operation);
  EXPECT_EQ(command_of(0x0080), DriveCommandWord::none);
}

TEST(Cia402Drive, EnablesThroughShutdownSwitchOnEnableOperation) {
  Cia402Drive d;
  EXPECT_EQ(d.state(), DriveState::switch_on_disabled);
  EXPECT_FALSE(d.follows_target_velocity());
  d.apply_controlword(controlword::kSwitchOn);  // not allowed from disabled
  EXPECT_EQ(d.state(), DriveState::switch_on_disabled);
  d.apply_controlword(controlword::kShutdown);
  EXPECT_EQ(d.state(), DriveState::ready_to_switch_on);
  d.apply_controlword(controlword::kSwitchOn);
  EXPECT_EQ(d.state(), DriveState::switched_on);
  d.apply_controlword(controlword::kEnableOperation);
  EXPECT_EQ(d.state(), DriveState::operation_enabled);
  EXPECT_EQ(d.statusword(), 0x0027);
  EXPECT_TRUE(d.follows_target_velocity());
}

TEST(Cia402Drive, LeavesOperationEnabledByEachCommand) {
  auto enabled = [] {
    Cia402Drive d;
    d.apply_controlword(controlword::kShutdown);
    d.apply_controlword(controlword::kEnableOperation);  // 3+4 from ready to switch on
    EXPECT_EQ(d.state(), DriveState::operation_enabled);
    return d;
  };
  auto d = enabled();
  d.apply_controlword(controlword::kSwitchOn);
  EXPECT_EQ(d.state(), DriveState::switched_on);
  d = enabled();
  d.apply_controlword(controlword::kShutdown);
  EXPECT_EQ(d.state(), DriveState::ready_to_switch_on);
  d = enabled();
  d.apply_controlword(controlword::kDisableVoltage);
  EXPECT_EQ(d.state(), DriveState::switch_on_disabled);
  d = enabled();
  d.apply_controlword(controlword::kQuickStop);
  EXPECT_EQ(d.state(), DriveState::quick_stop_active);
  EXPECT_FALSE(d.follows_target_velocity());
  d.apply_controlword(controlword::kEnableOperation);
  EXPECT_EQ(d.state(), DriveState::operation_enabled);
  d.apply_controlword(controlword::kQuickStop);
  d.apply_controlword(controlword::kDisableVoltage);
  EXPECT_EQ(d.state(), DriveState::switch_on_disabled);
}

TEST(Cia402Drive, FaultIgnoresCommandsUntilRisingEdgeOfBit7) {
  Cia402Drive d;
  d.apply_controlword(controlword::kShutdown);
  d.apply_controlword(controlword::kEnableOperation);
  d.raise_fault();
  EXPECT_EQ(d.state(), DriveState::fault);
  EXPECT_EQ(d.statusword(), 0x0008);
  EXPECT_FALSE(d.follows_target_velocity());
  d.apply_controlword(controlword::kEnableOperation);
  EXPECT_EQ(d.state(), DriveState::fault);
  d.apply_controlword(controlword::kFaultResetBit);
  EXPECT_EQ(d.state(), DriveState::switch_on_disabled);
}

TEST(Cia402Drive, FaultResetLevelHeldFromBeforeTheFaultIsNoEdge) {
  Cia402Drive d;
  d.apply_controlword(controlword::kFaultResetBit);  // bit 7 high before the fault
  d.raise_fault();
  d.apply_controlword(controlword::kFaultResetBit);  // still high: no rising edge
  EXPECT_EQ(d.state(), DriveState::fault);
  d.apply_controlword(0x0000);
  d.apply_controlword(controlword::kFaultResetBit);
  EXPECT_EQ(d.state(), DriveState::switch_on_disabled);
}

TEST(Cia402Enabler, ReachesOperationEnabledFromDisabledOneStepPerStatusword) {
  Cia402Drive drive;
  Cia402Enabler enabler;
  const std::uint16_t expected[] = {controlword::kShutdown, controlword::kSwitchOn,
                                    controlword::kEnableOperation};
  for (std::uint16_t cw : expected) {
    const std::uint16_t sent = enabler.next_controlword(drive.statusword(), false);
    EXPECT_EQ(sent, cw);
    drive.apply_controlword(sent);
  }
  EXPECT_EQ(drive.state(), DriveState::operation_enabled);
  EXPECT_EQ(enabler.next_controlword(drive.statusword(), false), controlword::kEnableOperation);
}

TEST(Cia402Enabler, LeavesAFaultAloneUnlessAskedToReset) {
  Cia402Drive drive;
  drive.raise_fault();
  Cia402Enabler enabler;
  for (int i = 0; i < 3; ++i) {
    const auto cw = enabler.next_controlword(drive.statusword(), false);
    EXPECT_EQ(cw, controlword::kDisableVoltage);
    drive.apply_controlword(cw);
  }
  EXPECT_EQ(drive.state(), DriveState::fault);
}

TEST(Cia402Enabler, ResetsAFaultWithARisingEdgeThenEnables) {
  Cia402Drive drive;
  drive.apply_controlword(controlword::kFaultResetBit);  // the drive last saw bit 7 high
  drive.raise_fault();
  Cia402Enabler enabler;
  int cycles = 0;
  while (drive.state() != DriveState::operation_enabled && cycles < 10) {
    drive.apply_controlword(enabler.next_controlword(drive.statusword(), true));
    ++cycles;
  }
  EXPECT_EQ(drive.state(), DriveState::operation_enabled);
  EXPECT_LE(cycles, 6);
}

TEST(Cia402Enabler, QuickStopActiveGoesStraightBackToOperationEnabled) {
  Cia402Drive drive;
  Cia402Enabler enabler;
  for (int i = 0; i < 3; ++i) drive.apply_controlword(enabler.next_controlword(drive.statusword(), false));
  drive.apply_controlword(controlword::kQuickStop);
  ASSERT_EQ(drive.state(), DriveState::quick_stop_active);
  const std::uint16_t cw = enabler.next_controlword(drive.statusword(), false);
  EXPECT_EQ(cw, controlword::kEnableOperation);
  drive.apply_controlword(cw);
  EXPECT_EQ(drive.state(), DriveState::operation_enabled) << "transition 16, one controlword";
}

TEST(Cia402Enabler, UnknownPatternsAndFaultReactionGetDisableVoltage) {
  Cia402Enabler enabler;
  EXPECT_EQ(enabler.next_controlword(0x0001, true), controlword::kDisableVoltage);
  EXPECT_EQ(enabler.next_controlword(statusword::kFaultReactionActive, true), controlword::kDisableVoltage);
}

}  // namespace
}  // namespace rtm::can
