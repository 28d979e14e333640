// SPDX-License-Identifier: Apache-2.0
// The SocketCAN transport and the master over a real kernel CAN stack (vcan0). CTest runs it in
// a QEMU guest through scripts/vm-vcan-run (label socketcan). Without a CAN stack or vcan0 every
// test fails, never skips: where it runs, both must be there.
#include <net/if.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <vector>

#include "arm/can/bus.h"
#include "arm/can/master.h"
#include "arm/can/sensor_listener.h"
#include "rtm_test/can/emulated_pa10.h"
#include "rtm_test/eventually.h"

namespace rtm::can {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;
using rtm_test::eventually;

class SocketCan : public ::testing::Test {
 protected:
  void SetUp() override {
    const int probe = ::socket(PF_CAN, SOCK_RAW, CAN_RAW);
    if (probe < 0) GTEST_FAIL() << "no SocketCAN in this kernel: run it through scripts/vm-vcan-run";
    ::close(probe);
    if (::if_nametoindex("vcan0") == 0) GTEST_FAIL() << "no vcan0 interface: run it through scripts/vm-vcan-run";
  }
};

can_frame frame(canid_t id, std::uint8_t dlc) {
  can_frame f{};
  f.can_id = id;
  f.can_dlc = dlc;
  for (std::uint8_t i = 0; i < dlc; ++i) f.data[i] = static_cast<std::uint8_t>(0xA0 + i);
  return f;
}

TEST_F(SocketCan, TwoSocketsExchangeFramesAndTheSenderDoesNotHearItself) {
  auto a = open_bus("socketcan:vcan0");
  auto b = open_bus("socketcan:vcan0");
  EXPECT_EQ(a->name(), "socketcan:vcan0");
  ASSERT_TRUE(a->send(frame(0x181, 8)));
  can_frame got{};
  ASSERT_TRUE(b->receive(got, 5'000'000'000));
  EXPECT_EQ(got.can_id, 0x181u);
  EXPECT_EQ(got.can_dlc, 8);
  EXPECT_EQ(got.data[7], 0xA7);
  EXPECT_FALSE(a->receive(got, 100'000'000));
  ASSERT_TRUE(b->send(frame(0x080, 1)));
  ASSERT_TRUE(a->receive(got, 5'000'000'000));
  EXPECT_EQ(got.can_id, 0x080u);
}

TEST_F(SocketCan, ABatchArrivesWholeAndInOrder) {
  auto a = open_bus("socketcan:vcan0");
  auto b = open_bus("socketcan:vcan0");
  std::vector<can_frame> batch;
  for (int i = 0; i < 8; ++i) {
    can_frame f = frame(static_cast<canid_t>(0x201 + i), 8);
    f.data[0] = static_cast<std::uint8_t>(i);
    batch.push_back(f);
  }
  EXPECT_EQ(a->send_batch(batch), batch.size());
  can_frame got{};
  for (int i = 0; i < 8; ++i) {
    ASSERT_TRUE(b->receive(got, 5'000'000'000)) << "frame " << i;
    EXPECT_EQ(got.can_id, static_cast<canid_t>(0x201 + i));
    EXPECT_EQ(got.data[0], i);
  }
  EXPECT_FALSE(b->receive(got, 100'000'000)) << "a frame sent twice";
}

TEST_F(SocketCan, KernelFiltersPassOnlyMatchingIds) {
  const FrameFilter heartbeats[] = {{0x700, 0x780}};
  auto listener = open_bus("socketcan:vcan0", heartbeats);
  auto sender = open_bus("socketcan:vcan0");
  sender->send(frame(0x181, 8));
  sender->send(frame(0x705, 1));
  can_frame got{};
  ASSERT_TRUE(listener->receive(got, 5'000'000'000));
  EXPECT_EQ(got.can_id, 0x705u);
  EXPECT_FALSE(listener->receive(got, 100'000'000));
}

TEST_F(SocketCan, MissingInterfaceIsNamedInTheError) {
  EXPECT_THAT([] { open_bus("socketcan:vcan9"); },
              ::testing::ThrowsMessage<BusError>(HasSubstr("no CAN interface 'vcan9'")));
  EXPECT_THAT([] { open_bus("socketcan:averyveryverylongname"); },
              ::testing::ThrowsMessage<BusError>(HasSubstr("longer than")));
}

TEST_F(SocketCan, MasterStartsTheEmulatedPa10AndExchangesPdos) {
  MasterConfig config;
  config.heartbeat_timeout_ns = 5'000'000'000;  // the guest's time is not real time
  config.step_timeout_ns = 2'000'000'000;
  config.enable_timeout_ns = 10'000'000'000;
  config.target_expiry_periods = 0;  // one target for all 100 lock-step cycles
  Pa10Master master("socketcan:vcan0", "", config);
  testing::EmulatedPa10 nodes("socketcan:vcan0");
  nodes.set_wrench(ForceSensor::wrist, {0, 0, -9.81, 0, 0, 0});
  SensorListener listener("socketcan:vcan0", ForceSensor::wrist);
  listener.start();
  master.start();
  ASSERT_TRUE(master.enabled());
  master.set_target_velocities({0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1});
  for (int i = 0; i < 100; ++i) ASSERT_TRUE(master.step()) << "step " << i;
  const JointState s = master.joint_state();
  EXPECT_TRUE(s.complete);
  EXPECT_NEAR(s.velocity_rad_s[0], 0.1, 1e-3);
  EXPECT_NEAR(master.wrench(ForceSensor::wrist).values[2], -9.81, 1e-9);
  const auto w = listener.wait_newer_than(0, 5'000'000'000);
  ASSERT_TRUE(w.has_value());
  EXPECT_NEAR(w->values[2], -9.81, 1e-9);

  // And the periodic thread over the same socket.
  master.run_periodic();
  ASSERT_TRUE(eventually([&] { return master.counters().cycles >= 300; }, 30s));  // the guest is slow
  master.stop();
  EXPECT_GE(master.counters().cycles, 300u);
  EXPECT_EQ(master.counters().malformed_frames, 0u);
  listener.stop();
}

}  // namespace
}  // namespace rtm::can
