// SPDX-License-Identifier: Apache-2.0
// The PA10 codec: every frame round-trips, scaling and saturation are exact, and every
// malformed input gives an error value.
#include "arm/can/protocol.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace rtm::can {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

can_frame raw(canid_t id, std::initializer_list<std::uint8_t> bytes) {
  can_frame f{};
  f.can_id = id;
  f.can_dlc = static_cast<std::uint8_t>(bytes.size());
  std::size_t i = 0;
  for (auto b : bytes) f.data[i++] = b;
  return f;
}

TEST(CanProtocol, NmtRoundTripsEveryCommand) {
  for (auto cmd : {NmtCommand::start, NmtCommand::stop, NmtCommand::enter_pre_operational,
                   NmtCommand::reset_node, NmtCommand::reset_communication}) {
    const auto f = encode_nmt(cmd, 5);
    ASSERT_TRUE(f);
    EXPECT_EQ(f->can_id, 0x000u);
    EXPECT_EQ(f->can_dlc, 2);
    const auto d = decode_nmt(*f);
    ASSERT_TRUE(d);
    EXPECT_EQ(d->command, cmd);
    EXPECT_EQ(d->node, 5);
  }
}

TEST(CanProtocol, NmtRejectsUnknownCommandWrongDlcAndNodeAbove127) {
  EXPECT_EQ(decode_nmt(raw(0x000, {0x03, 0})).error(), CodecError::unknown_command);
  EXPECT_EQ(decode_nmt(raw(0x000, {0x01})).error(), CodecError::wrong_dlc);
  EXPECT_EQ(decode_nmt(raw(0x000, {0x01, 128})).error(), CodecError::out_of_range);
  EXPECT_EQ(decode_nmt(raw(0x001, {0x01, 0})).error(), CodecError::wrong_cob_id);
  EXPECT_EQ(encode_nmt(NmtCommand::start, 200).error(), CodecError::wrong_cob_id);
  EXPECT_EQ(encode_nmt(static_cast<NmtCommand>(0x42), 0).error(), CodecError::unknown_command);
}

TEST(CanProtocol, SyncCounterRunsFrom1To240AndWraps) {
  EXPECT_EQ(next_sync_counter(0), 1);
  EXPECT_EQ(next_sync_counter(1), 2);
  EXPECT_EQ(next_sync_counter(239), 240);
  EXPECT_EQ(next_sync_counter(240), 1);
  for (int c = 1; c <= 240; ++c) {
    const auto f = encode_sync(static_cast<std::uint8_t>(c));
    ASSERT_TRUE(f);
    EXPECT_EQ(f->can_id, 0x080u);
    EXPECT_EQ(decode_sync(*f)->counter, c);
  }
  EXPECT_EQ(encode_sync(0).error(), CodecError::out_of_range);
  EXPECT_EQ(encode_sync(241).error(), CodecError::out_of_range);
  EXPECT_EQ(decode_sync(raw(0x080, {0})).error(), CodecError::out_of_range);
  EXPECT_EQ(decode_sync(raw(0x080, {241})).error(), CodecError::out_of_range);
  EXPECT_EQ(decode_sync(raw(0x080, {})).error(), CodecError::wrong_dlc);
}

TEST(CanProtocol, HeartbeatRoundTripsEveryStateAndRejectsOthers) {
  for (auto s : {NmtState::boot_up, NmtState::stopped, NmtState::operational, NmtState::pre_operational}) {
    const auto f = encode_heartbeat(0x11, s);
    ASSERT_TRUE(f);
    EXPECT_EQ(f->can_id, 0x711u);
    const auto d = decode_heartbeat(*f);
    ASSERT_TRUE(d);
    EXPECT_EQ(d->node, 0x11);
    EXPECT_EQ(d->state, s);
  }
  EXPECT_EQ(decode_heartbeat(raw(0x701, {0x06})).error(), CodecError::out_of_range);
  EXPECT_EQ(decode_heartbeat(raw(0x701, {0x05, 0})).error(), CodecError::wrong_dlc);
  EXPECT_EQ(decode_heartbeat(raw(0x700, {0x05})).error(), CodecError::wrong_cob_id);
  EXPECT_EQ(encode_heartbeat(0, NmtState::operational).error(), CodecError::wrong_cob_id);
}

TEST(CanProtocol, EmcyRoundTripsCodeAndRegisterLittleEndian) {
  const auto f = encode_emcy(4, emcy::kRpdoTimeout, 0x11);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->can_id, 0x084u);
  EXPECT_EQ(f->can_dlc, 8);
  EXPECT_EQ(f->data[0], 0x50);
  EXPECT_EQ(f->data[1], 0x82);
  const auto d = decode_emcy(*f);
  ASSERT_TRUE(d);
  EXPECT_EQ(d->node, 4);
  EXPECT_EQ(d->error_code, 0x8250);
  EXPECT_EQ(d->error_register, 0x11);
  EXPECT_EQ(decode_emcy(raw(0x084, {0x50, 0x82, 0})).error(), CodecError::wrong_dlc);
  EXPECT_EQ(emcy_description(emcy::kRpdoTimeout), "RPDO timeout (command loss)");
}

TEST(CanProtocol, DriveCommandScalesToMicroradPerSecond) {
  const auto f = encode_drive_command({3, controlword::kEnableOperation, 0.5});
  ASSERT_TRUE(f);
  EXPECT_EQ(f->can_id, 0x203u);
  EXPECT_EQ(f->can_dlc, 6);
  EXPECT_EQ(f->data[0], 0x0F);
  EXPECT_EQ(f->data[1], 0x00);
  // 0.5 rad/s = 500000 µrad/s = 0x0007A120, little-endian
  EXPECT_EQ(f->data[2], 0x20);
  EXPECT_EQ(f->data[3], 0xA1);
  EXPECT_EQ(f->data[4], 0x07);
  EXPECT_EQ(f->data[5], 0x00);
  const auto d = decode_drive_command(*f);
  ASSERT_TRUE(d);
  EXPECT_EQ(d->drive, 3);
  EXPECT_EQ(d->controlword, 0x000F);
  EXPECT_DOUBLE_EQ(d->target_velocity_rad_s, 0.5);
}

TEST(CanProtocol, DriveCommandRoundTripsNegativeAndSaturatesHuge) {
  const auto neg = decode_drive_command(*encode_drive_command({7, 0x0F, -1.234567}));
  EXPECT_NEAR(neg->target_velocity_rad_s, -1.234567, 1e-12);
  const auto hi = decode_drive_command(*encode_drive_command({1, 0x0F, 1e9}));
  EXPECT_NEAR(hi->target_velocity_rad_s, std::numeric_limits<std::int32_t>::max() * 1e-6, 1e-9);
  const auto lo = decode_drive_command(*encode_drive_command({1, 0x0F, -INFINITY}));
  EXPECT_NEAR(lo->target_velocity_rad_s, std::numeric_limits<std::int32_t>::min() * 1e-6, 1e-9);
}

TEST(CanProtocol, DriveCommandRejectsNaNAndNodesOutside1To7) {
  EXPECT_EQ(encode_drive_command({1, 0x0F, kNaN}).error(), CodecError::not_a_number);
  EXPECT_EQ(encode_drive_command({0, 0x0F, 0.0}).error(), CodecError::wrong_cob_id);
  EXPECT_EQ(encode_drive_command({8, 0x0F, 0.0}).error(), CodecError::wrong_cob_id);
  EXPECT_EQ(decode_drive_command(raw(0x208, {0, 0, 0, 0, 0, 0})).error(), CodecError::wrong_cob_id);
  EXPECT_EQ(decode_drive_command(raw(0x201, {0, 0, 0, 0, 0})).error(), CodecError::wrong_dlc);
  EXPECT_EQ(decode_drive_command(raw(0x201, {0, 0, 0, 0, 0, 0, 0, 0})).error(), CodecError::wrong_dlc);
}

TEST(CanProtocol, DriveFeedbackRoundTripsPositionMicroradAndVelocityMilliradPerSecond) {
  const auto f = encode_drive_feedback({2, statusword::kOperationEnabled, -1.5707963, 0.87654});
  ASSERT_TRUE(f);
  EXPECT_EQ(f->can_id, 0x182u);
  EXPECT_EQ(f->can_dlc, 8);
  const auto d = decode_drive_feedback(*f);
  ASSERT_TRUE(d);
  EXPECT_EQ(d->drive, 2);
  EXPECT_EQ(d->statusword, 0x0027);
  EXPECT_NEAR(d->position_rad, -1.570796, 1e-12);  // 1 µrad resolution
  EXPECT_NEAR(d->velocity_rad_s, 0.877, 1e-12);    // 1 mrad/s resolution, rounded
}

TEST(CanProtocol, DriveFeedbackVelocitySaturatesAtInt16) {
  const auto d = decode_drive_feedback(*encode_drive_feedback({1, 0, 0.0, 100.0}));
  EXPECT_NEAR(d->velocity_rad_s, 32.767, 1e-12);
  const auto n = decode_drive_feedback(*encode_drive_feedback({1, 0, 0.0, -100.0}));
  EXPECT_NEAR(n->velocity_rad_s, -32.768, 1e-12);
}

TEST(CanProtocol, DriveFeedbackRejectsNaNWrongDlcAndSensorIds) {
  EXPECT_EQ(encode_drive_feedback({1, 0, kNaN, 0}).error(), CodecError::not_a_number);
  EXPECT_EQ(encode_drive_feedback({1, 0, 0, kNaN}).error(), CodecError::not_a_number);
  EXPECT_EQ(decode_drive_feedback(raw(0x181, {0x27, 0, 1, 2, 3})).error(), CodecError::wrong_dlc);
  EXPECT_EQ(decode_drive_feedback(raw(0x190, {0, 0, 0, 0, 0, 0, 0, 0})).error(), CodecError::wrong_cob_id);
}

TEST(CanProtocol, SensorForceAndTorqueRoundTripWithTheirScales) {
  const auto f = encode_sensor_force({kWristSensorNode, {12.34, -0.01, 300.0}});
  ASSERT_TRUE(f);
  EXPECT_EQ(f->can_id, 0x190u);
  EXPECT_EQ(f->can_dlc, 6);
  const auto df = decode_sensor_force(*f);
  ASSERT_TRUE(df);
  EXPECT_EQ(df->node, kWristSensorNode);
  EXPECT_NEAR(df->force_N[0], 12.34, 1e-12);
  EXPECT_NEAR(df->force_N[1], -0.01, 1e-12);
  EXPECT_NEAR(df->force_N[2], 300.0, 1e-12);

  const auto t = encode_sensor_torque({kJoystickSensorNode, {1.234, -2.5, 0.0004}});
  ASSERT_TRUE(t);
  EXPECT_EQ(t->can_id, 0x291u);
  const auto dt = decode_sensor_torque(*t);
  ASSERT_TRUE(dt);
  EXPECT_EQ(dt->node, kJoystickSensorNode);
  EXPECT_NEAR(dt->torque_Nm[0], 1.234, 1e-12);
  EXPECT_NEAR(dt->torque_Nm[1], -2.5, 1e-12);
  EXPECT_NEAR(dt->torque_Nm[2], 0.0, 1e-12);  // below resolution rounds to 0
}

TEST(CanProtocol, SensorValuesSaturateAtInt16Range) {
  const auto f = decode_sensor_force(*encode_sensor_force({kWristSensorNode, {1e6, -1e6, 0}}));
  EXPECT_NEAR(f->force_N[0], 327.67, 1e-9);
  EXPECT_NEAR(f->force_N[1], -327.68, 1e-9);
  const auto t = decode_sensor_torque(*encode_sensor_torque({kWristSensorNode, {40.0, -40.0, 0}}));
  EXPECT_NEAR(t->torque_Nm[0], 32.767, 1e-9);
  EXPECT_NEAR(t->torque_Nm[1], -32.768, 1e-9);
}

TEST(CanProtocol, SensorFramesRejectNaNDriveNodesAndWrongDlc) {
  EXPECT_EQ(encode_sensor_force({kWristSensorNode, {0, kNaN, 0}}).error(), CodecError::not_a_number);
  EXPECT_EQ(encode_sensor_torque({kWristSensorNode, {kNaN, 0, 0}}).error(), CodecError::not_a_number);
  EXPECT_EQ(encode_sensor_force({3, {0, 0, 0}}).error(), CodecError::wrong_cob_id);
  EXPECT_EQ(decode_sensor_force(raw(0x190, {0, 0, 0, 0})).error(), CodecError::wrong_dlc);
  EXPECT_EQ(decode_sensor_torque(raw(0x290, {0, 0, 0, 0, 0, 0, 0})).error(), CodecError::wrong_dlc);
  EXPECT_EQ(decode_sensor_torque(raw(0x283, {0, 0, 0, 0, 0, 0})).error(), CodecError::wrong_cob_id);
}

TEST(CanProtocol, SdoDownloadOfEachSizeRoundTrips) {
  for (std::uint8_t size : {1, 2, 4}) {
    const std::uint32_t value = size == 1 ? 9u : size == 2 ? 0xBEEFu : 0xDEADBEEFu;
    const auto f = encode_sdo_request({2, SdoRequestKind::download, 0x6060, 0, value, size});
    ASSERT_TRUE(f);
    EXPECT_EQ(f->can_id, 0x602u);
    EXPECT_EQ(f->can_dlc, 8);
    EXPECT_EQ(f->data[0], size == 1 ? 0x2F : size == 2 ? 0x2B : 0x23);
    EXPECT_EQ(f->data[1], 0x60);
    EXPECT_EQ(f->data[2], 0x60);
    const auto d = decode_sdo_request(*f);
    ASSERT_TRUE(d);
    EXPECT_EQ(d->kind, SdoRequestKind::download);
    EXPECT_EQ(d->index, 0x6060);
    EXPECT_EQ(d->data, value);
    EXPECT_EQ(d->data_size, size);
  }
}

TEST(CanProtocol, SdoUploadRequestAndResponsesRoundTrip) {
  const auto up = encode_sdo_request({5, SdoRequestKind::upload, 0x6061, 0, 0, 0});
  ASSERT_TRUE(up);
  EXPECT_EQ(up->data[0], 0x40);
  EXPECT_EQ(decode_sdo_request(*up)->kind, SdoRequestKind::upload);

  const auto data = encode_sdo_response({5, SdoResponseKind::upload_data, 0x6061, 0, 9, 1});
  ASSERT_TRUE(data);
  EXPECT_EQ(data->can_id, 0x585u);
  EXPECT_EQ(data->data[0], 0x4F);
  const auto dd = decode_sdo_response(*data);
  EXPECT_EQ(dd->kind, SdoResponseKind::upload_data);
  EXPECT_EQ(dd->data, 9u);
  EXPECT_EQ(dd->data_size, 1);

  const auto ack = decode_sdo_response(*encode_sdo_response({5, SdoResponseKind::download_ack, 0x6060, 0, 0, 0}));
  EXPECT_EQ(ack->kind, SdoResponseKind::download_ack);
  EXPECT_EQ(ack->index, 0x6060);

  const auto abort = encode_sdo_response({5, SdoResponseKind::abort, 0x6060, 0, sdo::kAbortValueRange, 0});
  EXPECT_EQ(abort->data[0], 0x80);
  const auto da = decode_sdo_response(*abort);
  EXPECT_EQ(da->kind, SdoResponseKind::abort);
  EXPECT_EQ(da->data, sdo::kAbortValueRange);
}

TEST(CanProtocol, SdoRejectsUnknownCommandsBadSizesAndStrayBytes) {
  EXPECT_EQ(decode_sdo_request(raw(0x601, {0x22, 0x60, 0x60, 0, 9, 0, 0, 0})).error(), CodecError::unknown_command);
  EXPECT_EQ(decode_sdo_response(raw(0x581, {0x41, 0x61, 0x60, 0, 9, 0, 0, 0})).error(), CodecError::unknown_command);
  // 1-byte download carrying a second data byte
  EXPECT_EQ(decode_sdo_request(raw(0x601, {0x2F, 0x60, 0x60, 0, 9, 1, 0, 0})).error(), CodecError::out_of_range);
  EXPECT_EQ(decode_sdo_request(raw(0x601, {0x2F, 0x60, 0x60, 0})).error(), CodecError::wrong_dlc);
  EXPECT_EQ(encode_sdo_request({1, SdoRequestKind::download, 0x6060, 0, 9, 3}).error(), CodecError::out_of_range);
  EXPECT_EQ(encode_sdo_request({1, SdoRequestKind::download, 0x6060, 0, 0x100, 1}).error(), CodecError::out_of_range);
  EXPECT_EQ(encode_sdo_response({1, SdoResponseKind::upload_data, 0x6061, 0, 9, 0}).error(), CodecError::out_of_range);
  EXPECT_EQ(encode_sdo_request({0, SdoRequestKind::upload, 0x6061, 0, 0, 0}).error(), CodecError::wrong_cob_id);
}

TEST(CanProtocol, DecodersRefuseExtendedRtrAndErrorFrames) {
  can_frame f = *encode_sync(1);
  f.can_id |= CAN_EFF_FLAG;
  EXPECT_EQ(decode_sync(f).error(), CodecError::not_classic_frame);
  f.can_id = 0x181 | CAN_RTR_FLAG;
  f.can_dlc = 8;
  EXPECT_EQ(decode_drive_feedback(f).error(), CodecError::not_classic_frame);
  EXPECT_EQ(classify(f).type, FrameType::unknown);
  f.can_id = 0x080 | CAN_ERR_FLAG;
  EXPECT_EQ(classify(f).type, FrameType::unknown);
}

TEST(CanProtocol, DecodersNeverReadPastDlcEvenWithGarbageBeyond) {
  can_frame f{};
  f.can_id = 0x181;
  f.can_dlc = 15;  // impossible DLC: must be refused, not trusted
  EXPECT_EQ(decode_drive_feedback(f).error(), CodecError::wrong_dlc);
  EXPECT_EQ(classify(f).type, FrameType::drive_feedback);  // the id alone says what it claims
}

TEST(CanProtocol, ClassifySortsEveryIdOfTheProtocol) {
  auto type_of = [](canid_t id) { can_frame f{}; f.can_id = id; return classify(f); };
  EXPECT_EQ(type_of(0x000).type, FrameType::nmt);
  EXPECT_EQ(type_of(0x080).type, FrameType::sync);
  EXPECT_EQ(type_of(0x085).type, FrameType::emcy);
  EXPECT_EQ(type_of(0x085).node, 5);
  EXPECT_EQ(type_of(0x187).type, FrameType::drive_feedback);
  EXPECT_EQ(type_of(0x188).type, FrameType::unknown);
  EXPECT_EQ(type_of(0x190).type, FrameType::sensor_force);
  EXPECT_EQ(type_of(0x191).type, FrameType::sensor_force);
  EXPECT_EQ(type_of(0x201).type, FrameType::drive_command);
  EXPECT_EQ(type_of(0x210).type, FrameType::unknown);
  EXPECT_EQ(type_of(0x290).type, FrameType::sensor_torque);
  EXPECT_EQ(type_of(0x281).type, FrameType::unknown);
  EXPECT_EQ(type_of(0x583).type, FrameType::sdo_response);
  EXPECT_EQ(type_of(0x603).type, FrameType::sdo_request);
  EXPECT_EQ(type_of(0x711).type, FrameType::heartbeat);
  EXPECT_EQ(type_of(0x711).node, 0x11);
  EXPECT_EQ(type_of(0x123).type, FrameType::unknown);
  EXPECT_EQ(type_of(0x001).type, FrameType::unknown);
}

TEST(CanProtocol, NamesNodesForMessages) {
  EXPECT_EQ(node_description(4), "drive 4 (E1)");
  EXPECT_EQ(node_description(7), "drive 7 (W2)");
  EXPECT_EQ(node_description(0x10), "wrist sensor 0x10");
  EXPECT_EQ(node_description(0x11), "joystick sensor 0x11");
  EXPECT_EQ(node_description(0x2a), "node 0x2a");
  EXPECT_EQ(joint_name(-1), "?");
}

TEST(CanProtocol, ResultValueOnAnErrorThrowsWithTheReason) {
  const auto r = encode_sync(0);
  try {
    (void)r.value();
    FAIL() << "expected a logic_error";
  } catch (const std::logic_error& e) {
    EXPECT_NE(std::string(e.what()).find("out of range"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace rtm::can
