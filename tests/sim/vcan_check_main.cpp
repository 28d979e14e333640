// SPDX-License-Identifier: Apache-2.0
// Runs in a QEMU guest (scripts/vm-vcan-run) where vcan0 exists: pa10-sim and the
// arm library talk over real SocketCAN in lock-step while candump watches the bus.
// usage: sim_vcan_check <pa10-sim> <pa10.urdf>; prints "vcan check passed" and exits 0, or
// prints what failed and exits 1. Functional only: the guest does not keep real time.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <memory>
#include <string>

#include "arm/can/master.h"
#include "arm/pa10/arm.h"
#include "rtm_test/child_process.h"
#include "rtm_test/eventually.h"

using namespace std::chrono_literals;

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s <pa10-sim> <pa10.urdf>\n", argv[0]);
    return 2;
  }
  try {
    rtm_test::ChildProcess::Options quiet;
    quiet.echo_output = false;
    rtm_test::ChildProcess candump({"candump", "-L", "vcan0"}, quiet);
    rtm_test::ChildProcess sim({argv[1], "--bus", "socketcan:vcan0", "--lockstep"});
    sim.wait_for_line("pa10-sim: ready", 60s);

    rtm::can::MasterConfig config;
    config.step_timeout_ns = 5'000'000'000;
    config.boot_timeout_ns = 30'000'000'000;
    config.sdo_timeout_ns = 5'000'000'000;
    config.enable_timeout_ns = 30'000'000'000;
    config.heartbeat_timeout_ns = 10'000'000'000;  // the guest's clock is not real time
    double moved_rad = 0;
    {
      rtm::can::Pa10Master master("socketcan:vcan0", "", config);
      master.start();
      rtm::pa10::Pa10Arm arm(argv[2], master);
      const auto q0 = arm.joint_positions();
      for (int i = 0; i < 100; ++i) {
        if (arm.order_velocity({0.05f, 0, 0, 0, 0, 0}) != rtm::can::FaultKind::none)
          throw std::runtime_error("arm fault: " + arm.fault_reason());
        if (!master.step()) throw std::runtime_error("a node did not answer a SYNC");
      }
      moved_rad = (arm.joint_positions() - q0).norm();
    }
    sim.stop();
    struct Expected {
      const char* text;
      const char* what;
    };
    const Expected expected[] = {Expected{" 080#", "SYNC"}, Expected{" 201#", "drive 1 RPDO1"},
                                 Expected{" 187#", "drive 7 TPDO1"}, Expected{" 190#", "wrist force TPDO1"},
                                 Expected{" 291#", "joystick torque TPDO2"},
                                 Expected{" 701#", "drive 1 heartbeat"}};
    // candump prints what it has read: each kind below, or what it has by the bound.
    rtm_test::eventually([&] {
      for (const Expected& e : expected)
        if (candump.count_lines(e.text) == 0) return false;
      return true;
    });
    candump.stop();
    if (!(moved_rad > 1e-3)) throw std::runtime_error("the arm did not move over vcan0");
    for (const Expected& e : expected) {
      const std::size_t seen = candump.count_lines(e.text);
      std::printf("candump saw %zu %s frames\n", seen, e.what);
      if (seen == 0) throw std::runtime_error(std::string("candump saw no ") + e.what);
    }
    std::printf("vcan check passed: joints moved %.4f rad over socketcan:vcan0\n", moved_rad);
    return 0;
  } catch (const std::exception& error) {
    std::printf("vcan check failed: %s\n", error.what());
    return 1;
  }
}
