// SPDX-License-Identifier: Apache-2.0
// How fast the PA10 master stops the arm when another node attacks its bus: for each attack
// (a second master's RPDO + SYNC after each of our SYNCs, a spoofed wrist-force TPDO, a
// spoofed drive TPDO), N trials against the master on its periodic 2 ms thread and pa10-sim's
// CAN nodes on a kinematic plant (as in tests/can/master_attack_test.cpp). Each trial counts,
// in the order the frames crossed the bus, the master's SYNCs from the first attack frame to
// the one that latched the quick stop, then checks that no joint moved over the next 100 ms
// while the attack went on. Quiet, then beside a process that keeps one CPU busy.
//
//   can_attack_bench [--trials N] [--neighbour none|busy|both]
//
// Prints one row per attack and condition: trials, the fault kind each latched, the
// distribution of SYNCs until quick stop, the most any joint moved after it, and the master's
// overruns (cycles that started late: host stalls) during the trials.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "busy_neighbour.h"
#include "rtm_test/can/attacker.h"
#include "rtm_test/can/master_rig.h"

namespace {

using namespace rtm::can;
using rtm::can::testing::Attacker;
using rtm::can::testing::Rig;

using rtm_bench::BusyNeighbour;

struct Attack {
  const char* name;
  FaultKind expected;
  Attacker::Frames frames;
};

struct Trial {
  bool stopped = false;
  FaultKind kind = FaultKind::none;
  int syncs = -1;
  double moved_after_rad = 0;
  std::uint64_t overruns = 0;
};

Trial run_trial(const Attack& attack) {
  Rig rig;
  rig.master->start();
  rig.master->set_target_velocities({});
  rig.master->run_periodic();
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  Trial t;
  Attacker attacker(rig.spec, attack.frames);
  t.stopped = attacker.wait_for_stop();
  t.syncs = attacker.syncs_until_quick_stop();
  t.kind = rig.master->fault().kind;
  std::array<double, kDriveCount> at_stop{};
  for (int j = 0; j < kDriveCount; ++j) at_stop[static_cast<std::size_t>(j)] = rig.nodes->position_rad(drive_node(j));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  for (int j = 0; j < kDriveCount; ++j)
    t.moved_after_rad = std::max(t.moved_after_rad,
                                 std::abs(rig.nodes->position_rad(drive_node(j)) - at_stop[static_cast<std::size_t>(j)]));
  attacker.stop();
  t.overruns = rig.master->counters().overruns;
  rig.master->stop();
  return t;
}

void run_rows(const std::vector<Attack>& attacks, int trials, const char* condition) {
  for (const Attack& attack : attacks) {
    std::map<int, int> histogram;
    int right_kind = 0;
    int not_stopped = 0;
    double moved_after = 0;
    std::uint64_t overruns = 0;
    for (int i = 0; i < trials; ++i) {
      const Trial t = run_trial(attack);
      if (!t.stopped) ++not_stopped;
      if (t.kind == attack.expected) ++right_kind;
      ++histogram[t.syncs];
      moved_after = std::max(moved_after, t.moved_after_rad);
      overruns += t.overruns;
    }
    std::string dist;
    for (const auto& [syncs, n] : histogram) {
      char item[32];
      std::snprintf(item, sizeof item, " %d:%d", syncs, n);
      dist += item;
    }
    std::printf("%-22s %-6s trials %3d  %s %3d/%d  not stopped %d  SYNCs to quick stop {%s }  moved after %.0f urad  overruns %llu\n",
                attack.name, condition, trials, std::string(to_string(attack.expected)).c_str(), right_kind, trials,
                not_stopped, dist.c_str(), moved_after * 1e6, static_cast<unsigned long long>(overruns));
    std::fflush(stdout);
  }
}

}  // namespace

int main(int argc, char** argv) {
  int trials = 20;
  std::string neighbour = "both";
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--trials" && i + 1 < argc) {
      trials = std::atoi(argv[++i]);
    } else if (arg == "--neighbour" && i + 1 < argc) {
      neighbour = argv[++i];
    } else {
      std::fprintf(stderr, "usage: %s [--trials N] [--neighbour none|busy|both]\n", argv[0]);
      return 2;
    }
  }
  if (trials < 1 || (neighbour != "none" && neighbour != "busy" && neighbour != "both")) {
    std::fprintf(stderr, "%s: --trials must be >= 1, --neighbour none|busy|both\n", argv[0]);
    return 2;
  }
  const std::vector<Attack> attacks{
      {"second master", FaultKind::foreign_master,
       [](std::uint8_t counter) {
         return std::vector<can_frame>{*encode_drive_command({drive_node(0), controlword::kEnableOperation, 0.5}),
                                       *encode_sync(counter)};
       }},
      {"spoofed wrist force", FaultKind::spoofed_frame,
       [](std::uint8_t) { return std::vector<can_frame>{*encode_sensor_force({kWristSensorNode, {0, 0, -50}})}; }},
      {"spoofed drive TPDO", FaultKind::spoofed_frame,
       [](std::uint8_t) {
         return std::vector<can_frame>{*encode_drive_feedback({drive_node(2), statusword::kOperationEnabled, 1.0, 0.0})};
       }},
  };
  if (neighbour != "busy") run_rows(attacks, trials, "quiet");
  if (neighbour != "none") {
    BusyNeighbour busy;
    run_rows(attacks, trials, "busy");
  }
  return 0;
}
