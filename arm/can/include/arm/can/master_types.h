// SPDX-License-Identifier: Apache-2.0
// The PA10 master's vocabulary: its configuration and what it reports (joint state, wrench,
// fault (kinds in fault.h), counters, the last target sent). Shared by the master (master.h), its thread-free bus
// cycle (bus_cycle.h), its supervisor (supervisor.h) and the passive listeners (sensor_listener.h,
// joint_listener.h).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "arm/can/fault.h"
#include "arm/can/protocol.h"

namespace rtm::can {

// Times are std::int64_t nanoseconds named *_ns; points in time are CLOCK_MONOTONIC
// (rtm::monotonic_ns(), rt/clock.h), like everywhere else in the project.
struct MasterConfig {
  std::int64_t period_ns = 2'000'000;                // SYNC period
  std::int64_t boot_timeout_ns = 5'000'000'000;      // all nodes seen (boot-up/heartbeat)
  std::int64_t sdo_timeout_ns = 500'000'000;         // per SDO request
  std::int64_t enable_timeout_ns = 2'000'000'000;    // all drives operation enabled
  std::int64_t heartbeat_timeout_ns = 300'000'000;   // node silent longer -> fault
  std::int64_t step_timeout_ns = 100'000'000;        // lock-step wait
  // A drive that does not answer more consecutive SYNCs -> FaultKind::missing_feedback.
  // 25 cycles = 50 ms. Only windows closed on time count (receive() within 1.5 periods of the
  // SYNC): when the master's own cycle ran late, its process or the whole host stalled (these
  // VMs show 100-120 ms), and the nodes may have stalled with it (counted as stalled_windows).
  // A dead node is caught by the heartbeat after heartbeat_timeout_ns anyway. 1..10000.
  int missed_feedback_limit = 25;
  // A TPDO answers one of our last `answer_expiry_periods` SYNCs (1..256, see answer_ledger.h);
  // one more than a node was asked for is a spoofed frame (FaultKind::spoofed_frame). Longer
  // than the stalls a simulated node on a loaded host shows before answering a backlog.
  int answer_expiry_periods = 64;
  // Following error (CiA 402's velocity and following-error windows), while the master commands
  // the drives:
  //   velocity: a drive's actual velocity against the command acting since the previous SYNC;
  //   position: how far it moved over the last following_position_periods SYNCs against the
  //             integral of its commands over them (a sliding window, so a long press on a
  //             surface, where the small command integrates while the arm stays, never adds up).
  // Outside either window for more than following_error_periods SYNCs in a row ->
  // FaultKind::following_error. 0 turns a window off. docs/safety.md: how the defaults were chosen.
  double following_velocity_window_rad_s = 0.3;
  double following_position_window_rad = 0.1;
  int following_position_periods = 250;  // 0.5 s at 2 ms; 1..1000
  int following_error_periods = 25;
  // Force sensors the master listens to (and waits for at startup and in step()).
  std::vector<ForceSensor> sensors{ForceSensor::wrist, ForceSensor::joystick};
  // While another thread runs the cycles (take_over_cycles()): if it sends no SYNC for this
  // many periods in a row in which the master's SYNC watchdog itself woke on time (so not a
  // stall of the whole process or host), the watchdog gives the cycles back to the master's
  // own activity and latches FaultKind::cycle_owner_lost (zero velocity). Without it a hung
  // owner would leave each drive at its last latched velocity: the drives' RPDO timeout counts
  // SYNCs, and none come. 0: no watchdog.
  int taken_over_timeout_periods = 5;
  // A target not renewed (set_target_velocities) for this many cycles in a row has expired:
  // the master commands zero from then on, counts it (target_expiries) and moves again with
  // the next target. Without it a thread that hangs after setting a target leaves the arm
  // moving at that velocity for as long as the cycles run. 25 cycles = 50 ms, as
  // missed_feedback_limit. 0: a target holds until replaced, for callers that set one target
  // and then run several lock-step cycles on it. 0..10000.
  int target_expiry_periods = 25;
  // run_periodic(): SCHED_FIFO priority (0 = keep SCHED_OTHER) and CPU to pin to (-1 = none).
  int realtime_priority = 0;
  int cpu = -1;
  // run_periodic(): CLOCK_MONOTONIC deadline of the first cycle; 0 = at once. A time already
  // past puts the cycles on the grid first_deadline_ns + k * period_ns (rt/schedule.h
  // first_deadline), where components with a --phase run too: SYNC can follow the cycle that
  // hands the drives their command.
  std::int64_t first_deadline_ns = 0;
};

struct JointState {
  std::array<double, kDriveCount> position_rad{};
  std::array<double, kDriveCount> velocity_rad_s{};
  std::array<std::uint16_t, kDriveCount> statusword{};
  std::uint8_t sync_counter = 0;  // the SYNC these values answer (0 = none yet)
  std::int64_t sync_time_ns = 0;  // when that SYNC was sent (master) or received (listener), CLOCK_MONOTONIC
  std::uint64_t cycle = 0;        // cycle number of that SYNC, counting from 1 (listener: SYNCs heard)
  bool complete = false;          // all 7 drives answered that SYNC
};

struct Wrench {
  std::array<double, 6> values{};  // Fx Fy Fz [N], Tx Ty Tz [N·m], in the sensor frame
  std::uint8_t sync_counter = 0;   // the SYNC the force and torque frames answer (0 = none yet)
  std::int64_t sync_time_ns = 0;   // when that SYNC was sent (master) or received (listener), CLOCK_MONOTONIC
  std::uint64_t sequence = 0;      // increments with each complete wrench (force + torque)
  bool valid = false;
};

// The master's latched fault; reason e.g. "drive 4 (E1): EMCY 0x8250 RPDO timeout (command loss)".
using MasterFault = Fault;

struct MasterCounters {
  std::uint64_t cycles = 0;            // SYNCs sent
  std::uint64_t overruns = 0;          // run_periodic: cycle found its deadline already past
  std::uint64_t step_timeouts = 0;     // step(): not all expected TPDOs within step_timeout_ns
  std::uint64_t stalled_windows = 0;   // receive() ran so late that silence did not count
  std::uint64_t malformed_frames = 0;  // protocol id, but the decoder refused it
  std::uint64_t unknown_frames = 0;    // id outside the protocol
  std::uint64_t late_frames = 0;       // TPDO answering an older SYNC: ignored
  std::uint64_t foreign_frames = 0;    // master-side frames (SYNC, NMT, RPDO, SDO request) from another master
  std::uint64_t unsolicited_frames = 0;  // TPDOs beyond what a node was asked for (answer_ledger.h)
  // The largest following errors seen while commanding (rad/s, rad): what the windows above
  // leave as margin on this arm and load.
  double peak_velocity_error_rad_s = 0;
  double peak_position_error_rad = 0;
  std::uint64_t emcy_frames = 0;
  std::uint64_t send_dropped = 0;      // transmit queue full
  std::uint64_t target_expiries = 0;   // targets not renewed within target_expiry_periods
};

// The last target that left for the bus: see Pa10Master::last_sent().
struct SentTarget {
  std::uint64_t sequence = 0;
  std::int64_t sent_realtime_ns = 0;
};

}  // namespace rtm::can
