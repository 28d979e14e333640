// SPDX-License-Identifier: Apache-2.0
// The Sensor component's fault policy with its real bus source (BusForceSource: SensorListener
// and JointListener) against pa10-sim's CAN nodes (tests/support/rtm_test/can/emulated_pa10.h: the simulator's
// own ForceSensorDevice and DriveDevices, in lock-step) on the user-space bus. The test is the
// bus master: NMT start, then one SYNC per step. The wrist sensor node is cut off the bus as a
// pulled cable is (ForceSensorDevice::set_connected(false): no TPDO, no heartbeat):
//   - a heartbeat loss writes nothing, is counted once, and is recovered from when the node's
//     heartbeat and a new wrench are back;
//   - silence beyond the recovery budget, or an EMCY of the sensor, is COMPONENT_ERROR.
// Heartbeat silence is measured on a manual clock that the test moves (rtm_test::ManualClock):
// a pulled cable's timeout passes in one step, and a node that is connected is never silent
// however slow the machine. What they assert is counted in cycles, never timed.
#include "components/sensor/sensor.h"

#include "host/runner.h"

#include "arm/can/local_bus.h"
#include "component_test_support.h"
#include "rtm_test/can/emulated_pa10.h"
#include "rtm_test/can/master_rig.h"
#include "rtm_test/eventually.h"
#include "rtm_test/manual_clock.h"
#include "rtm_test/can/test_paths.h"

#include <CLI/CLI.hpp>
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <thread>

namespace {

using namespace std::chrono_literals;
namespace pc = rtm::can;
using rtm::comp::FaultKind;
using rtm_test::eventually;

// eventually()'s bound here. Generous: a loaded 2-core VM may stall the nodes' thread for a
// long time.
constexpr auto kDeadline = 30s;

double force_magnitude(const RTM::TimedFloat6& d) {
  return std::sqrt(double(d.val[0]) * d.val[0] + double(d.val[1]) * d.val[1] + double(d.val[2]) * d.val[2]);
}

struct SensorOnTheBus {
  pc::testing::TempDir dir;
  pc::LocalHub hub{dir.file("bus")};
  std::string spec = "local:" + dir.file("bus");
  std::unique_ptr<pc::Bus> master_side;  // the test as the bus master: NMT and SYNC
  std::unique_ptr<pc::testing::EmulatedPa10> nodes;
  rtm_test::ManualClock clock;  // what the wrist node's heartbeat silence is measured on
  rtm::comp::BusForceSource* source = nullptr;  // owned by the sensor
  std::unique_ptr<rtm::comp::Sensor> sensor;
  std::uint8_t sync_counter = 0;
  std::uint64_t n = 0;

  explicit SensorOnTheBus(rtm::comp::SensorParams params = {}) {
    // No frame is for the master side: it receives nothing (the hub would queue them).
    const pc::FrameFilter nothing[] = {{0x7ff, 0x7ff}};
    master_side = pc::open_bus(spec, nothing);
    // Listening before the nodes power on, so the wrist's boot-up message counts as heard.
    auto bus_source = std::make_unique<rtm::comp::BusForceSource>(
        spec, pc::ForceSensor::wrist, spec, rtm::comp::BusForceSource::kDefaultHeartbeatTimeout_ns, clock);
    source = bus_source.get();
    sensor = rtm::comp::Sensor::wrist("sensor0", std::move(bus_source), rtm::pa10::Kinematics::pa10(), params);
    nodes = std::make_unique<pc::testing::EmulatedPa10>(spec);
    nodes->set_wrench(pc::ForceSensor::wrist, {0, 0, -10, 0, 0, 0});
    master_side->send(*pc::encode_nmt(pc::NmtCommand::start, pc::kNmtAllNodes));
    sensor->on_start();
  }
  ~SensorOnTheBus() {
    sensor.reset();  // the listeners first, then the nodes, then the hub
    nodes.reset();
  }

  void sync() {
    sync_counter = static_cast<std::uint8_t>(sync_counter % 240 + 1);
    master_side->send(*pc::encode_sync(sync_counter));
  }
  // One SYNC and the wrench that answers it (with a full joint vector).
  bool sync_and_wait_for_wrench() {
    const std::uint64_t before = source->latest().sequence;
    sync();
    return eventually(
        [&] {
          const auto s = source->latest();
          return s.valid && s.q_valid && s.sequence > before;
        },
        kDeadline);
  }
  // Until the nodes have taken every SYNC sent so far (drive 1 has seen the last one).
  bool wait_until_the_nodes_caught_up() {
    return eventually([&] { return nodes->last_sync_counter() == sync_counter; }, kDeadline);
  }
  void cycle() { sensor->on_cycle(comp_test::cycle(n++)); }
  RTM::TimedFloat6 last_datum() {
    RTM::TimedFloat6 d{};
    sensor->out().latest(d);
    return d;
  }

  // Steps until the first datum is written.
  void run_healthy() {
    for (int i = 0; i < 3; ++i) {
      ASSERT_TRUE(sync_and_wait_for_wrench()) << "no wrench from the wrist sensor node";
      cycle();
    }
    ASSERT_EQ(sensor->counters().samples, 3u);
    ASSERT_NEAR(force_magnitude(last_datum()), 10.0, 0.02);
  }

  // Cuts the wrist node off and steps (a SYNC each cycle, the drives still answering, the
  // clock a heartbeat timeout on) until the sensor has seen the heartbeat loss: at the latest
  // once a heartbeat still on its way when the cable was pulled has been read. Nothing may be
  // written meanwhile.
  void pull_the_cable() {
    const std::uint64_t written = sensor->counters().samples;
    nodes->set_connected(pc::kWristSensorNode, false);
    const bool lost = eventually(
        [&] {
          sync();
          clock.advance(rtm::comp::BusForceSource::kDefaultHeartbeatTimeout_ns + 1'000'000);
          cycle();
          EXPECT_EQ(sensor->counters().samples, written) << "a datum was written while the node was silent";
          return sensor->counters().heartbeat_losses > 0;
        },
        kDeadline);
    ASSERT_TRUE(lost) << "the heartbeat loss was never seen";
    ASSERT_TRUE(sensor->in_heartbeat_loss());
  }
};

TEST(SensorRecovery, HeartbeatLossOfTheWristNodeWritesNothingAndIsCountedOnce) {
  SensorOnTheBus t;
  t.run_healthy();
  const RTM::TimedFloat6 before = t.last_datum();
  t.pull_the_cable();
  // More cycles of silence: still nothing written, still one event.
  for (int i = 0; i < 50; ++i) {
    t.sync();
    t.cycle();
  }
  EXPECT_EQ(t.sensor->counters().samples, 3u);
  const RTM::TimedFloat6 after = t.last_datum();
  EXPECT_EQ(rtm::to_ns(after.tm), rtm::to_ns(before.tm)) << "the out port holds a datum written during the loss";
  EXPECT_EQ(t.sensor->counters().heartbeat_losses, 1u);
  EXPECT_EQ(t.sensor->counters().heartbeat_recoveries, 0u);
  // What `rtm cat sensor0` shows.
  EXPECT_EQ(comp_test::statistic(*t.sensor, "heartbeat_losses"), 1.0);
  EXPECT_EQ(comp_test::statistic(*t.sensor, "heartbeat_recoveries"), 0.0);
}

TEST(SensorRecovery, HeartbeatBackResumesWritingWithAWrenchNewerThanTheLoss) {
  SensorOnTheBus t;
  t.run_healthy();
  t.pull_the_cable();
  const std::int64_t loss_seen_ns = rtm::to_ns(rtm::now());
  for (int i = 0; i < 10; ++i) {
    t.sync();
    t.cycle();
  }
  // The SYNCs of the loss were answered without the wrist node: none is left for it to answer
  // once it is back.
  ASSERT_TRUE(t.wait_until_the_nodes_caught_up());
  // While cut off, the wrench on the tool changes: 20 N now.
  t.nodes->set_wrench(pc::ForceSensor::wrist, {0, 0, -20, 0, 0, 0});
  t.nodes->set_connected(pc::kWristSensorNode, true);
  // Its heartbeat comes back (every 100 ms); no cycle runs meanwhile, so none counts
  // against the budget however slow the machine is.
  ASSERT_TRUE(eventually([&] { return t.source->fault_kind() == FaultKind::none; }, kDeadline))
      << t.source->fault().reason;
  // Heartbeat back, but no new wrench yet: nothing to write.
  t.cycle();
  EXPECT_EQ(t.sensor->counters().samples, 3u);
  EXPECT_EQ(t.sensor->counters().heartbeat_recoveries, 0u);
  EXPECT_TRUE(t.sensor->in_heartbeat_loss());
  // The next SYNC's wrench is written.
  ASSERT_TRUE(t.sync_and_wait_for_wrench());
  t.cycle();
  EXPECT_EQ(t.sensor->counters().samples, 4u);
  EXPECT_EQ(t.sensor->counters().heartbeat_recoveries, 1u);
  EXPECT_FALSE(t.sensor->in_heartbeat_loss());
  const RTM::TimedFloat6 first = t.last_datum();
  EXPECT_NEAR(force_magnitude(first), 20.0, 0.02) << "not the wrench measured after the loss";
  EXPECT_GT(rtm::to_ns(first.tm), loss_seen_ns);
  // And it goes on, one datum per SYNC, one recovery in all.
  for (int i = 0; i < 5; ++i) {
    ASSERT_TRUE(t.sync_and_wait_for_wrench());
    t.cycle();
  }
  EXPECT_EQ(t.sensor->counters().samples, 9u);
  EXPECT_EQ(t.sensor->counters().heartbeat_losses, 1u);
  EXPECT_EQ(comp_test::statistic(*t.sensor, "heartbeat_recoveries"), 1.0);
}

TEST(SensorRecovery, SilenceBeyondTheRecoveryBudgetIsAnErrorNamingTheNodeAndTheSilence) {
  rtm::comp::SensorParams params;
  params.recovery_timeout_periods = 5;
  SensorOnTheBus t(params);
  t.run_healthy();
  t.pull_the_cable();
  std::string reason;
  int cycles_after_loss = 0;
  for (; cycles_after_loss < 100 && reason.empty(); ++cycles_after_loss) {
    t.sync();
    try {
      t.cycle();
    } catch (const std::runtime_error& e) {
      reason = e.what();
    }
  }
  ASSERT_FALSE(reason.empty()) << "the sensor waited beyond its budget";
  EXPECT_EQ(cycles_after_loss, 5) << "the budget counts cycles from the loss";
  EXPECT_NE(reason.find("wrist sensor 0x10"), std::string::npos) << reason;
  EXPECT_NE(reason.find("no heartbeat for"), std::string::npos) << reason;
  EXPECT_NE(reason.find("recovery budget of 5 cycles (10 ms)"), std::string::npos) << reason;
  EXPECT_EQ(t.sensor->counters().samples, 3u);
  EXPECT_EQ(t.sensor->counters().heartbeat_recoveries, 0u);
}

TEST(SensorRecovery, AnEmcyOfTheSensorIsAnErrorAtOnceNotAHeartbeatLoss) {
  SensorOnTheBus t;
  t.run_healthy();
  // Beyond the i16 range of the PDO (327.67 N): the node reports the saturated reading and
  // EMCY 0x7300 (sensor fault).
  t.nodes->set_wrench(pc::ForceSensor::wrist, {0, 0, -1000, 0, 0, 0});
  ASSERT_TRUE(t.sync_and_wait_for_wrench());
  t.cycle();  // that SYNC's (saturated) wrench
  ASSERT_TRUE(eventually([&] { return t.source->fault_kind() == FaultKind::emergency; }, kDeadline))
      << "the EMCY was never heard";
  // The very next cycle without a new wrench fails; the heartbeat is fine all along.
  try {
    t.cycle();
    FAIL() << "an EMCY of the sensor did not put the component in error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("wrist sensor 0x10: EMCY 0x7300"), std::string::npos) << e.what();
  }
  EXPECT_EQ(t.sensor->counters().heartbeat_losses, 0u);
  EXPECT_FALSE(t.sensor->in_heartbeat_loss());
}

// The shared tick (rtm-servo, the closed-loop tests): the Pa10Master of the process owns the
// wrist node. It latches the node's heartbeat loss as its own fault (the actuator's error);
// the sensor takes it as a heartbeat loss too, and resumes once the master's fault reset (the
// actuator's on() after reset()) cleared it and a new wrench came, not before.
TEST(SensorRecoverySharedTick, TheMastersWristHeartbeatLossIsTheSensorsAndClearsWithTheMastersFaultReset) {
  pc::MasterConfig config = pc::testing::test_config();
  config.heartbeat_timeout_ns = 300'000'000;
  config.step_timeout_ns = 20'000'000;  // the silenced sensor's TPDOs stop too
  pc::testing::Rig rig({}, config);
  rig.nodes->set_wrench(pc::ForceSensor::wrist, {0, 0, -10, 0, 0, 0});
  rig.master->start();
  rtm::comp::SensorParams params;
  params.recovery_timeout_periods = rtm::comp::SensorParams::kMaxRecoveryTimeoutPeriods;  // never the limit here
  rtm::comp::Sensor sensor("sensor0", pc::ForceSensor::wrist,
                           std::make_unique<rtm::comp::MasterForceSource>(*rig.master, pc::ForceSensor::wrist),
                           rtm::pa10::Kinematics::pa10(), params);
  sensor.on_start();
  std::uint64_t n = 0;
  auto step = [&] {
    rig.master->step();
    sensor.on_cycle(comp_test::cycle(n++));
  };
  for (int i = 0; i < 5; ++i) step();
  const std::uint64_t written = sensor.counters().samples;
  ASSERT_GT(written, 0u);

  rig.nodes->set_connected(pc::kWristSensorNode, false);
  ASSERT_TRUE(eventually(
      [&] {
        step();
        return sensor.counters().heartbeat_losses > 0;
      },
      kDeadline));
  const pc::MasterFault fault = rig.master->fault();
  EXPECT_EQ(fault.kind, pc::FaultKind::heartbeat_lost) << "the master holds it: the actuator goes to error";
  EXPECT_EQ(fault.node, pc::kWristSensorNode);

  rig.nodes->set_connected(pc::kWristSensorNode, true);
  ASSERT_TRUE(eventually(
      [&] {
        const std::uint64_t before = rig.master->wrench(pc::ForceSensor::wrist).sequence;
        step();
        return rig.master->wrench(pc::ForceSensor::wrist).sequence > before;
      },
      kDeadline))
      << "the master never heard the wrist node again";
  // Wrenches again, but the master still holds the fault: nothing written.
  for (int i = 0; i < 5; ++i) step();
  EXPECT_EQ(sensor.counters().samples, written);
  EXPECT_EQ(sensor.counters().heartbeat_recoveries, 0u);

  rig.master->fault_reset();
  ASSERT_TRUE(eventually(
      [&] {
        step();
        return sensor.counters().heartbeat_recoveries > 0;
      },
      kDeadline))
      << rig.master->fault().reason;
  EXPECT_EQ(sensor.counters().samples, written + 1);
  EXPECT_EQ(sensor.counters().heartbeat_losses, 1u);
}

TEST(SensorParams, ARecoveryBudgetOfZeroCyclesIsRefusedNamingIt) {
  rtm::comp::SensorParams zero;
  zero.recovery_timeout_periods = 0;
  try {
    zero.validate();
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("recovery_timeout_periods must be at least 1"), std::string::npos)
        << e.what();
  }
  rtm::comp::SensorParams too_long;
  too_long.recovery_timeout_periods = rtm::comp::SensorParams::kMaxRecoveryTimeoutPeriods + 1;
  EXPECT_THROW(too_long.validate(), std::invalid_argument);

  // The component refuses it before it listens to anything.
  pc::testing::TempDir dir;
  pc::LocalHub hub(dir.file("bus"));
  const std::string spec = "local:" + dir.file("bus");
  EXPECT_THROW(rtm::comp::Sensor::wrist("sensor0",
                                        std::make_unique<rtm::comp::BusForceSource>(spec, pc::ForceSensor::wrist, spec),
                                        rtm::pa10::Kinematics::pa10(), zero),
               std::invalid_argument);

  // The command line (rtm-sensor --recovery-timeout-periods) checks the same range.
  rtm::comp::SensorParams parsed;
  CLI::App app;
  rtm::add_parameter_options(app, rtm::comp::sensor_parameters(), parsed);
  try {
    app.parse("--recovery-timeout-periods 0", false);
    FAIL() << "0 was taken";
  } catch (const CLI::ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("not in range 1 to 30000"), std::string::npos) << e.what();
  }
  EXPECT_EQ(parsed.recovery_timeout_periods, 1000u) << "the default: 2 s at 2 ms";
}

TEST(SensorParams, TheRecoveryBudgetIsAParameterSetWhileOffInRange) {
  pc::testing::TempDir dir;
  pc::LocalHub hub(dir.file("bus"));
  const std::string spec = "local:" + dir.file("bus");
  rtm::comp::Sensor sensor("sensor0", pc::ForceSensor::wrist,
                           std::make_unique<rtm::comp::BusForceSource>(spec, pc::ForceSensor::wrist, spec),
                           rtm::pa10::Kinematics::pa10());
  const rtm::Parameter& p = comp_test::parameter(sensor, "recovery_timeout_periods");
  EXPECT_EQ(p.access, rtm::ParameterAccess::when_off);
  EXPECT_EQ(p.unit, "cycles");
  EXPECT_EQ(p.get(), "1000");
  EXPECT_THROW(p.set("0"), std::invalid_argument);
  EXPECT_EQ(p.get(), "1000") << "a refused value changed nothing";
  p.set("250");
  EXPECT_EQ(sensor.params().recovery_timeout_periods, 250u);
}

}  // namespace
