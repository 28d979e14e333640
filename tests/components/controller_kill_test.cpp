// SPDX-License-Identifier: Apache-2.0
// The paper's system in real time, one process per member over a real omniNames, on pa10-sim:
// the joystick pushes the arm through free space, the controller process is killed with
// SIGKILL, and a passive listener on the bus checks that the arm is brought to a halt.
//
// What "stops" means here, in bus time (SYNC periods), never wall-clock:
//   1. the actuator's watchdog fires after `watchdog_periods` periods without a new command
//      (it reports the bus cycle of its last command and of the firing);
//   2. the drives are braked: the RPDOs of every drive carry controlword 0x0002 (CiA 402 quick
//      stop) and zero target with the first SYNC the master sends after the firing: at most 2
//      SYNCs after the one whose answers the actuator had seen (one more of slack for a
//      preemption of the actuator's thread);
//   3. every drive reports "quick stop active" (statusword 0x0007) and |velocity| below
//      kStopped_rad_s within 3 SYNCs of the SYNC that carried the quick stop (pa10-sim's
//      drives engage their brake in that state; a drive merely commanded zero would decelerate
//      over ~50 ms through its velocity loop).
// Until the kill the RPDOs carried non-zero targets: the arm was moving.
#include "arm/can/bus.h"
#include "arm/can/protocol.h"
#include "rtm/naming.h"
#include "rtm/orb.h"
#include "rtm_test/child_process.h"
#include "rtm_test/eventually.h"
#include "rtm_test/omni_names.h"

#include <RTMExt.hh>

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>
#include <vector>

namespace {

using namespace std::chrono_literals;
using rtm_test::eventually;
namespace pc = rtm::can;

constexpr double kStopped_rad_s = 1e-3;
constexpr int kWatchdogPeriods = 3;
constexpr int kSyncsToHalt = 3;

std::filesystem::path unique_path(const std::string& stem, const std::string& ext) {
  static std::atomic<int> counter{0};
  return std::filesystem::temp_directory_path() /
         (stem + "-" + std::to_string(::getpid()) + "-" + std::to_string(counter++) + ext);
}

// One frame of interest, as the listener saw it, in bus order.
struct Seen {
  enum class Kind { sync, command, feedback } kind;
  std::uint8_t sync_counter = 0;  // sync
  std::uint8_t node = 0;          // command, feedback
  std::uint16_t word = 0;         // controlword or statusword
  double velocity_rad_s = 0;      // target or actual
};

// A passive endpoint on the bus: records SYNCs, RPDO1s and TPDO1s until destroyed.
class BusRecorder {
 public:
  explicit BusRecorder(const std::string& spec) : bus_(pc::open_bus(spec)) {
    thread_ = std::thread([this] { run(); });
  }
  ~BusRecorder() {
    running_ = false;
    thread_.join();
  }
  std::vector<Seen> frames() const {
    std::lock_guard lock(mutex_);
    return frames_;
  }
  // SYNCs recorded so far: a cheap look, where frames() copies the whole recording.
  std::size_t syncs() const { return syncs_.load(); }

 private:
  void run() {
    can_frame frame{};
    while (running_) {
      try {
        if (!bus_->receive(frame, 20'000'000)) continue;
      } catch (const pc::BusError&) {
        return;  // the simulator (the hub) went away
      }
      std::optional<Seen> seen;
      switch (pc::classify(frame).type) {
        case pc::FrameType::sync:
          if (auto s = pc::decode_sync(frame)) seen = Seen{Seen::Kind::sync, s->counter};
          break;
        case pc::FrameType::drive_command:
          if (auto c = pc::decode_drive_command(frame))
            seen = Seen{Seen::Kind::command, 0, c->drive, c->controlword, c->target_velocity_rad_s};
          break;
        case pc::FrameType::drive_feedback:
          if (auto f = pc::decode_drive_feedback(frame))
            seen = Seen{Seen::Kind::feedback, 0, f->drive, f->statusword, f->velocity_rad_s};
          break;
        default: break;
      }
      if (!seen) continue;
      std::lock_guard lock(mutex_);
      frames_.push_back(*seen);
      if (seen->kind == Seen::Kind::sync) ++syncs_;
    }
  }

  std::unique_ptr<pc::Bus> bus_;
  std::atomic<bool> running_{true};
  std::thread thread_;
  mutable std::mutex mutex_;
  std::vector<Seen> frames_;
  std::atomic<std::size_t> syncs_{0};
};

// Index of the last SYNC with this counter at or before `before`, or -1.
long last_sync_with_counter(const std::vector<Seen>& frames, std::uint8_t counter, long before) {
  for (long i = before; i >= 0; --i) {
    const Seen& f = frames[static_cast<std::size_t>(i)];
    if (f.kind == Seen::Kind::sync && f.sync_counter == counter) return i;
  }
  return -1;
}

long syncs_between(const std::vector<Seen>& frames, long from, long to) {
  long n = 0;
  for (long i = from + 1; i <= to; ++i) n += frames[static_cast<std::size_t>(i)].kind == Seen::Kind::sync;
  return n;
}

// The n-th line (from 1) of `output` that contains `text`, or "".
std::string nth_line_with(const std::string& output, const std::string& text, std::size_t n) {
  std::istringstream lines(output);
  std::size_t seen = 0;
  for (std::string line; std::getline(lines, line);)
    if (line.find(text) != std::string::npos && ++seen == n) return line;
  return "";
}

// The actuator's watchdog line: "since bus cycle A (SYNC counter a): quick stop after bus
// cycle B (SYNC counter b)".
struct WatchdogEvent {
  long last_command_cycle = 0, fired_cycle = 0;
  std::uint8_t last_command_counter = 0, fired_counter = 0;
};
std::optional<WatchdogEvent> parse_watchdog_event(const std::string& line) {
  const std::size_t since = line.find("since bus cycle");
  if (since == std::string::npos) return std::nullopt;
  WatchdogEvent e;
  int last_counter = 0, fired_counter = 0;
  if (std::sscanf(line.c_str() + since,
                  "since bus cycle %ld (SYNC counter %d): quick stop after bus cycle %ld (SYNC counter %d)",
                  &e.last_command_cycle, &last_counter, &e.fired_cycle, &fired_counter) != 4)
    return std::nullopt;
  e.last_command_counter = static_cast<std::uint8_t>(last_counter);
  e.fired_counter = static_cast<std::uint8_t>(fired_counter);
  return e;
}

// Index of the first SYNC with this counter at or after `from`, or -1.
long first_sync_with_counter(const std::vector<Seen>& frames, std::uint8_t counter, long from) {
  for (long i = from; i < static_cast<long>(frames.size()); ++i) {
    const Seen& f = frames[static_cast<std::size_t>(i)];
    if (f.kind == Seen::Kind::sync && f.sync_counter == counter) return i;
  }
  return -1;
}

// Index of the first SYNC after `after` before which every drive got quick stop with zero
// target, or -1.
long first_quick_stop_sync(const std::vector<Seen>& frames, long after) {
  std::array<bool, pc::kDriveCount> commanded{};
  for (auto i = static_cast<std::size_t>(after) + 1; i < frames.size(); ++i) {
    const Seen& f = frames[i];
    if (f.kind == Seen::Kind::command && pc::is_drive_node(f.node)) {
      commanded[static_cast<std::size_t>(pc::joint_index_of(f.node))] =
          f.word == pc::controlword::kQuickStop && f.velocity_rad_s == 0.0;
    } else if (f.kind == Seen::Kind::sync && std::ranges::all_of(commanded, [](bool b) { return b; })) {
      return static_cast<long>(i);
    }
  }
  return -1;
}

// A non-zero target among the RPDOs of the 8 cycles before frame `before`.
bool moving_before(const std::vector<Seen>& frames, long before) {
  for (long i = before - 1; i >= 0 && i >= before - 8 * 8; --i) {
    const Seen& f = frames[static_cast<std::size_t>(i)];
    if (f.kind == Seen::Kind::command && std::abs(f.velocity_rad_s) > 1e-4) return true;
  }
  return false;
}

// SYNCs after `quick_stop_sync` until every drive reported quick stop active at rest, or -1
// when not within kSyncsToHalt + 1.
long syncs_until_halted(const std::vector<Seen>& frames, long quick_stop_sync) {
  std::array<bool, pc::kDriveCount> halted{};
  long syncs = 0;
  for (auto i = static_cast<std::size_t>(quick_stop_sync); i < frames.size() && syncs <= kSyncsToHalt + 1; ++i) {
    const Seen& f = frames[i];
    if (f.kind == Seen::Kind::sync) {
      if (i != static_cast<std::size_t>(quick_stop_sync)) ++syncs;
      continue;
    }
    if (f.kind != Seen::Kind::feedback || !pc::is_drive_node(f.node)) continue;
    halted[static_cast<std::size_t>(pc::joint_index_of(f.node))] =
        f.word == pc::statusword::kQuickStopActive && std::abs(f.velocity_rad_s) < kStopped_rad_s;
    if (std::ranges::all_of(halted, [](bool b) { return b; })) return syncs;
  }
  return -1;
}

// Non-zero targets on the bus for 100 cycles, within `timeout`.
bool wait_until_moving(const BusRecorder& recorder, std::chrono::seconds timeout) {
  const auto moving = [&] {
    int nonzero = 0;
    for (const Seen& f : recorder.frames())
      nonzero += f.kind == Seen::Kind::command && std::abs(f.velocity_rad_s) > 1e-4;
    return nonzero > 7 * 100;
  };
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!moving() && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(50ms);
  return moving();
}

rtm::Orb& test_orb() {
  static rtm::Orb orb;  // omniORB: one ORB per process
  return orb;
}

// pa10-sim and the paper's five members as processes on one bus and a test's omniNames, with
// a passive recorder on the bus; the joystick's operator pushes forward (free space) from 0.3 s
// on and keeps pushing. Members are stopped in the reverse order of their start.
struct PaperSystem {
  using Child = rtm_test::ChildProcess;
  PaperSystem() {
    std::ofstream(profile) << "segments:\n"
                              "  - hold: 0.3\n"
                              "  - ramp: {duration_s: 0.2, force_N: [5, 0, 0]}\n"
                              "  - hold: 600\n";
    sim = std::make_unique<Child>(std::vector<std::string>{PA10_SIM_EXE, "--bus", bus, "--profile", profile.string()});
    sim->wait_for_line("pa10-sim: ready", 30s);
    recorder = std::make_unique<BusRecorder>(bus);
    actuator = member({RTM_ACTUATOR_EXE, "--name", "actuator0", "--bus", bus, "--watchdog-periods",
                       std::to_string(kWatchdogPeriods)});
    actuator->wait_until_bound(30s);  // the CAN master is up before the others start
    sensor = member({RTM_SENSOR_EXE, "--name", "sensor0", "--bus", bus});
    joystick = member({RTM_JOYSTICK_EXE, "--name", "joystick0", "--bus", bus});
    controller = member({RTM_CONTROLLER_EXE, "--name", "controller0", "--gain", "0.003", "0.003", "0.003", "0", "0", "0"});
    for (Child* c : {sensor.get(), joystick.get(), controller.get()}) c->wait_until_bound(30s);
    servo = member({RTM_SERVO_EXE, "--name", "servo0", "--sensor", "sensor0", "--controller", "controller0",
                    "--actuator", "actuator0"});
    servo->wait_until_bound(30s);
  }
  ~PaperSystem() {
    std::error_code ignored;
    std::filesystem::remove(profile, ignored);  // pa10-sim read it at start
  }
  std::unique_ptr<Child> member(std::vector<std::string> argv) const {
    argv.insert(argv.end(), {"--naming", naming});
    return std::make_unique<Child>(std::move(argv));
  }

  const std::filesystem::path profile = unique_path("rtm-kill-profile", ".yaml");
  const std::string bus = "local:" + unique_path("rtm-kill", ".bus").string();
  rtm_test::OmniNames names;
  const std::string naming = names.address();
  std::unique_ptr<Child> sim;
  std::unique_ptr<BusRecorder> recorder;
  std::unique_ptr<Child> actuator, sensor, joystick, controller, servo;
};

enum class Victim { controller, sensor, joystick };

// The paper's procedure: joystick.out0 -> servo.in0, then on() the servo and the joystick.
void turn_on_the_paper_way(RTM::RtComponent_ptr servo, RTM::RtComponent_ptr joystick) {
  RTM::OutPortList_var joystick_outs = joystick->out_ports();
  RTM::InPortList_var servo_ins = servo->in_ports();
  ASSERT_TRUE(joystick_outs[0]->subscribe(RTM::repeated, servo_ins[0]));
  servo->on();
  joystick->on();
}

// `rtm ls` once the controller is gone: the controller is dead, the servo that exposes its
// reference InPort answers and is alive, that one port unreachable; `--clean` unbinds the
// controller only.
void expect_ls_tells_the_dead_member_from_the_live_composite(const std::string& naming) {
  auto rtm_cli = [&](std::vector<std::string> extra) {
    std::vector<std::string> argv{RTM_CLI_EXE, "--naming", naming};
    argv.insert(argv.end(), extra.begin(), extra.end());
    rtm_test::ChildProcess::Options quiet;
    quiet.echo_output = false;
    rtm_test::ChildProcess rtm(argv, quiet);
    rtm.wait_for_exit(30s);
    return rtm.output();
  };
  const std::string listing = rtm_cli({"ls", "-l"});
  std::istringstream lines(listing);
  std::string line, servo_line, controller_line;
  // A component's own line starts with its name (the wiring lines under it name peers).
  while (std::getline(lines, line)) {
    if (line.rfind("  servo0 ", 0) == 0 && servo_line.empty()) servo_line = line;
    if (line.rfind("  controller0 ", 0) == 0 && controller_line.empty()) controller_line = line;
  }
  EXPECT_NE(controller_line.find("dead"), std::string::npos) << listing;
  EXPECT_EQ(servo_line.find("dead"), std::string::npos) << "the live composite called dead:\n" << listing;
  const std::string servo = rtm_cli({"cat", "servo0"});
  // TRANSIENT as a rule (nothing listens where the controller did); OBJECT_NOT_EXIST when
  // another test's ORB took its TCP port meanwhile and answered that it has no such object.
  EXPECT_NE(servo.find("unreachable ("), std::string::npos) << servo;
  EXPECT_NE(servo.find("the process serving this port is gone"), std::string::npos) << servo;
  rtm_cli({"ls", "--clean"});
  const std::string after = rtm_cli({"ls"});
  EXPECT_NE(after.find("servo0"), std::string::npos) << "--clean unbound the live composite:\n" << after;
  EXPECT_EQ(after.find("controller0"), std::string::npos) << after;
}

// Kills one member of the running loop and checks the brake: the actuator's watchdog fires
// (the controller's command stops, or the controller withholds it once an input went stale)
// and every drive gets quick stop within 3 SYNCs of the firing, at rest within 3 more.
void check_loop_member_kill(Victim victim) {
  PaperSystem system;
  const std::string& naming = system.naming;
  BusRecorder& recorder = *system.recorder;
  rtm_test::ChildProcess& actuator = *system.actuator;

  const rtm::NamingClient client(test_orb().orb(), rtm::NamingAddress::parse(naming));
  RTM::RtComponent_var servo_ref = client.resolve_component("servo0");
  RTM::RtComponent_var joystick_ref = client.resolve_component("joystick0");
  ASSERT_NO_FATAL_FAILURE(turn_on_the_paper_way(servo_ref, joystick_ref));

  ASSERT_TRUE(wait_until_moving(recorder, 60s)) << "the arm never moved\n" << actuator.output();

  // A loaded machine may have stalled the controller before (a watchdog event and a quick
  // stop the next command released): the event that counts is the one after the kill. Every
  // frame recorded so far was on the bus before the kill.
  const std::string kWatchdog = "watchdog: no new command";
  const std::size_t events_before = actuator.count_lines(kWatchdog);
  const auto frames_before_kill = static_cast<long>(recorder.frames().size());
  (victim == Victim::controller ? system.controller : victim == Victim::sensor ? system.sensor : system.joystick)
      ->kill_now();
  eventually([&] { return actuator.count_lines(kWatchdog) != events_before; }, 30s);
  const std::string event = nth_line_with(actuator.output(), kWatchdog, events_before + 1);
  ASSERT_FALSE(event.empty()) << "no watchdog event after the kill\n" << actuator.output();
  // The halt and some more SYNCs reach the recorder: 100 SYNCs, 200 ms of the 2 ms period.
  const std::size_t syncs_at_event = recorder.syncs();
  eventually([&] { return recorder.syncs() >= syncs_at_event + 100; });
  const std::vector<Seen> frames = recorder.frames();
  if (victim != Victim::joystick) joystick_ref->off();
  servo_ref->off();

  const std::optional<WatchdogEvent> parsed = parse_watchdog_event(event);
  ASSERT_TRUE(parsed) << event;
  const WatchdogEvent& e = *parsed;
  // The watchdog counts the actuator's own cycles; the bus position it reports comes from the
  // master's thread, which may lag one SYNC behind on a loaded machine.
  EXPECT_GE(e.fired_cycle - e.last_command_cycle, kWatchdogPeriods - 1) << event;

  // The firing's SYNC was sent after the kill, so after every frame recorded before it.
  const long fired_sync = first_sync_with_counter(frames, e.fired_counter, frames_before_kill);
  ASSERT_GE(fired_sync, 0) << "the recorder missed SYNC " << int(e.fired_counter);

  // The first SYNC after the firing before which every drive got quick stop with zero target.
  const long quick_stop_sync = first_quick_stop_sync(frames, fired_sync);
  ASSERT_GE(quick_stop_sync, 0) << "no quick stop reached every drive\n" << actuator.output();

  // Before it, the arm was moving: the last command cycle's RPDOs were not zero.
  EXPECT_TRUE(moving_before(frames, quick_stop_sync)) << "the RPDOs before the quick stop already held zero";

  const long brake_delay = syncs_between(frames, fired_sync, quick_stop_sync);
  EXPECT_GE(brake_delay, 1);
  // The firing's bus position is the SYNC whose answers the actuator had seen; the SYNC after
  // it may already be on its way, so the quick stop leaves with the second one (+1 of slack
  // for a preemption of the actuator's thread between reading the position and braking).
  EXPECT_LE(brake_delay, 3) << "SYNCs from the watchdog firing to the one carrying the quick stop";
  const long last_command_sync = last_sync_with_counter(frames, e.last_command_counter, fired_sync);
  if (last_command_sync >= 0) {
    // Shown, not asserted: the actuator's own thread can be preempted on a loaded machine.
    std::fprintf(stderr, "kill test: last command after SYNC %d, watchdog after %ld SYNCs more, quick stop %ld SYNC(s) later\n",
                 int(e.last_command_counter), syncs_between(frames, last_command_sync, fired_sync), brake_delay);
  }

  // Halted: every drive reports quick stop active and no motion within 3 SYNCs.
  const long halted_after = syncs_until_halted(frames, quick_stop_sync);
  ASSERT_GE(halted_after, 0) << "the drives did not all report quick stop active at rest";
  EXPECT_LE(halted_after, kSyncsToHalt) << "SYNCs after the quick stop until every drive was at rest";
  std::fprintf(stderr, "kill test: every drive at rest %ld SYNC(s) after the one that carried the quick stop\n", halted_after);

  // Shown, not asserted: from the last frame before the kill to the quick stop.
  std::fprintf(stderr, "kill test: quick stop %ld SYNC(s) after the kill\n",
               syncs_between(frames, frames_before_kill > 0 ? frames_before_kill - 1 : 0, quick_stop_sync));
  EXPECT_EQ(actuator.count_lines(kWatchdog), events_before + 1) << "one event for the kill, logged once";
  if (victim == Victim::controller) expect_ls_tells_the_dead_member_from_the_live_composite(naming);
}

TEST(ControllerKill, TheArmIsBrakedWithinThreeSyncsOfTheActuatorWatchdog) { check_loop_member_kill(Victim::controller); }

// Losing an input of the loop brakes as losing the controller does: the controller withholds
// its command and the actuator's watchdog brakes (before, the command went to zero and the
// drives coasted down through their velocity loops for ~0.45 s).
TEST(LoopMemberKill, KillingTheSensorBrakesTheArmThroughTheActuatorWatchdog) { check_loop_member_kill(Victim::sensor); }

TEST(LoopMemberKill, KillingTheJoystickBrakesTheArmThroughTheActuatorWatchdog) {
  check_loop_member_kill(Victim::joystick);
}

// The composite dies: its members must not run on, wired and moving the arm, out of reach of
// anything named servo0. They turn themselves off once the servo stops renewing its hold.
TEST(CompositeKill, KillingTheServoTurnsItsMembersOffWithinItsLease) {
  PaperSystem system;
  const rtm::NamingClient client(test_orb().orb(), rtm::NamingAddress::parse(system.naming));
  RTM::RtComponent_var servo_ref = client.resolve_component("servo0");
  RTM::RtComponent_var joystick_ref = client.resolve_component("joystick0");
  ASSERT_NO_FATAL_FAILURE(turn_on_the_paper_way(servo_ref, joystick_ref));
  ASSERT_TRUE(wait_until_moving(*system.recorder, 60s)) << "the arm never moved\n" << system.actuator->output();
  std::vector<RTM::RtComponentEx_var> members;
  for (const char* name : {"sensor0", "controller0", "actuator0"}) {
    RTM::RtComponent_var plain = client.resolve_component(name);
    RTM::RtComponentEx_var m = RTM::RtComponentEx::_narrow(plain);
    ASSERT_EQ(m->state(), RTM::COMPONENT_ON) << name;
    members.push_back(m);
  }
  system.servo->kill_now();
  const auto killed = std::chrono::steady_clock::now();
  for (auto& m : members) {
    eventually([&] { return m->state() != RTM::COMPONENT_ON; });
    EXPECT_EQ(m->state(), RTM::COMPONENT_OFF) << m->name() << " still runs after its composite died";
  }
  std::fprintf(stderr, "composite kill: every member off %lld ms after the kill (the servo's lease: 500 ms)\n",
               static_cast<long long>(std::chrono::duration_cast<std::chrono::milliseconds>(
                                          std::chrono::steady_clock::now() - killed)
                                          .count()));
  EXPECT_NE(system.actuator->output().find("servo0 stopped renewing its hold"), std::string::npos);
  joystick_ref->off();
}

}  // namespace
