// SPDX-License-Identifier: Apache-2.0
// The emulated force/torque sensor: taring, scaling to the PDO units, saturation, NMT gating.
#include "sim/force_sensor_device.h"

#include <gtest/gtest.h>

#include <cmath>

#include "arm/can/protocol.h"
#include "recording_sink.h"

namespace pc = rtm::can;
using rtm::sim::ForceSensorConfig;
using rtm::sim::ForceSensorDevice;
using rtm::sim::Wrench;
using rtm::sim::testing::RecordingSink;

namespace {

constexpr std::uint8_t kNode = pc::kWristSensorNode;

class ForceSensorDeviceTest : public ::testing::Test {
 protected:
  explicit ForceSensorDeviceTest(int tare_samples = 4)
      : sensor_(ForceSensorConfig{kNode, 100'000'000, tare_samples}) {
    sensor_.power_on(0, out_);
  }
  void feed(const pc::Result<can_frame>& frame) {
    ASSERT_TRUE(frame.ok());
    sensor_.on_frame(*frame, 0, out_);
  }
  void start() { feed(pc::encode_nmt(pc::NmtCommand::start, 0)); }
  void sync() { feed(pc::encode_sync(1)); }
  // Reports `raw` after a SYNC and decodes what went on the bus.
  std::pair<pc::SensorForce, pc::SensorTorque> report(const Wrench& raw) {
    out_.clear();
    sync();
    sensor_.send_tpdo(raw, out_);
    const auto forces = out_.with_id(pc::cob::kTpdo1Base + kNode);
    const auto torques = out_.with_id(pc::cob::kTpdo2Base + kNode);
    EXPECT_EQ(forces.size(), 1u);
    EXPECT_EQ(torques.size(), 1u);
    if (forces.empty() || torques.empty()) return {};
    return {*pc::decode_sensor_force(forces[0]), *pc::decode_sensor_torque(torques[0])};
  }

  ForceSensorDevice sensor_;
  RecordingSink out_;
};

Wrench wrench(double fx, double fy, double fz, double tx, double ty, double tz) {
  return Wrench{{fx, fy, fz}, {tx, ty, tz}};
}

TEST_F(ForceSensorDeviceTest, TareIsTheAverageOfTheFirstSamplesAndIsSubtracted) {
  sensor_.add_tare_sample(wrench(1.0, 0, 2.0, 0.1, 0, 0));
  sensor_.add_tare_sample(wrench(1.2, 0, 2.2, 0.3, 0, 0));
  sensor_.add_tare_sample(wrench(0.8, 0, 1.8, 0.1, 0, 0));
  EXPECT_FALSE(sensor_.tared());
  sensor_.add_tare_sample(wrench(1.0, 0, 2.0, 0.3, 0, 0));
  EXPECT_TRUE(sensor_.tared());
  sensor_.add_tare_sample(wrench(100, 100, 100, 100, 100, 100));  // ignored once tared
  EXPECT_DOUBLE_EQ(sensor_.offset().force_N[0], 1.0);
  EXPECT_DOUBLE_EQ(sensor_.offset().force_N[2], 2.0);
  EXPECT_DOUBLE_EQ(sensor_.offset().torque_Nm[0], 0.2);
  start();
  const auto [force, torque] = report(wrench(1.0, 5.0, 12.0, 0.2, -0.5, 0));
  EXPECT_NEAR(force.force_N[0], 0.0, 1e-9);
  EXPECT_NEAR(force.force_N[1], 5.0, 1e-9);
  EXPECT_NEAR(force.force_N[2], 10.0, 1e-9);
  EXPECT_NEAR(torque.torque_Nm[0], 0.0, 1e-9);
  EXPECT_NEAR(torque.torque_Nm[1], -0.5, 1e-9);
}

TEST_F(ForceSensorDeviceTest, ScalesToHundredthsOfNewtonAndMillinewtonMetres) {
  const auto counts = sensor_.to_counts(wrench(12.345, -5.678, 0.004, 0.1234, -0.0016, 3.0));
  EXPECT_EQ(counts.force[0], 1235);  // rounded to the nearest count
  EXPECT_EQ(counts.force[1], -568);
  EXPECT_EQ(counts.force[2], 0);
  EXPECT_EQ(counts.torque[0], 123);
  EXPECT_EQ(counts.torque[1], -2);
  EXPECT_EQ(counts.torque[2], 3000);
  EXPECT_FALSE(counts.saturated);
}

TEST_F(ForceSensorDeviceTest, OutOfRangeSaturatesAndRaisesSensorFaultOnceThenClears) {
  start();
  const auto [force, torque] = report(wrench(400.0, -400.0, 0, 40.0, 0, 0));
  EXPECT_NEAR(force.force_N[0], 327.67, 1e-9);
  EXPECT_NEAR(force.force_N[1], -327.68, 1e-9);
  EXPECT_NEAR(torque.torque_Nm[0], 32.767, 1e-9);
  auto emcy = out_.with_id(pc::cob::kEmcyBase + kNode);
  ASSERT_EQ(emcy.size(), 1u);
  EXPECT_EQ(pc::decode_emcy(emcy[0])->error_code, pc::emcy::kSensorFault);
  report(wrench(400.0, 0, 0, 0, 0, 0));
  EXPECT_TRUE(out_.with_id(pc::cob::kEmcyBase + kNode).empty()) << "reported once";
  report(wrench(1.0, 0, 0, 0, 0, 0));
  emcy = out_.with_id(pc::cob::kEmcyBase + kNode);
  ASSERT_EQ(emcy.size(), 1u);
  EXPECT_EQ(pc::decode_emcy(emcy[0])->error_code, pc::emcy::kErrorReset);
}

TEST_F(ForceSensorDeviceTest, NanReadingIsReportedAsSensorFaultNotSent) {
  start();
  report(wrench(std::nan(""), 0, 0, 0, 0, 0));
  const auto emcy = out_.with_id(pc::cob::kEmcyBase + kNode);
  ASSERT_EQ(emcy.size(), 1u);
  EXPECT_EQ(pc::decode_emcy(emcy[0])->error_code, pc::emcy::kSensorFault);
}

TEST_F(ForceSensorDeviceTest, SendsNothingBeforeNmtStartOrWithoutSync) {
  sync();
  sensor_.send_tpdo(wrench(1, 2, 3, 0, 0, 0), out_);
  EXPECT_EQ(out_.frames.size(), 1u) << "only the boot-up message";
  start();
  sensor_.send_tpdo(wrench(1, 2, 3, 0, 0, 0), out_);
  EXPECT_EQ(out_.frames.size(), 1u) << "no SYNC since start";
  sync();
  sensor_.send_tpdo(wrench(1, 2, 3, 0, 0, 0), out_);
  EXPECT_EQ(out_.frames.size(), 3u);
}

TEST_F(ForceSensorDeviceTest, BootsUpAndBeatsEvery100ms) {
  ASSERT_EQ(out_.frames.size(), 1u);
  EXPECT_EQ(pc::decode_heartbeat(out_.frames[0])->state, pc::NmtState::boot_up);
  sensor_.tick(99'000'000, out_);
  EXPECT_EQ(out_.frames.size(), 1u);
  sensor_.tick(100'000'000, out_);
  ASSERT_EQ(out_.frames.size(), 2u);
  EXPECT_EQ(pc::decode_heartbeat(out_.frames[1])->state, pc::NmtState::pre_operational);
}

TEST_F(ForceSensorDeviceTest, ADisconnectedSensorNeitherHearsNorSends) {
  start();
  sensor_.set_connected(false);
  out_.clear();
  sync();
  sensor_.send_tpdo(wrench(1, 2, 3, 0, 0, 0), out_);
  sensor_.send_heartbeat(out_);
  sensor_.tick(1'000'000'000, out_);
  EXPECT_TRUE(out_.frames.empty());
  EXPECT_EQ(sensor_.last_sync_counter(), 0) << "it never heard the SYNC";
  sensor_.set_connected(true);
  feed(pc::encode_sync(7));
  sensor_.send_tpdo(wrench(1, 2, 3, 0, 0, 0), out_);
  EXPECT_EQ(out_.frames.size(), 2u);
  EXPECT_EQ(sensor_.last_sync_counter(), 7);
}

}  // namespace
