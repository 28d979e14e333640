// SPDX-License-Identifier: Apache-2.0
// pa10-sim's main loop: a Pa10Simulator behind a CAN bus (SocketCAN or the local hub).
//
// Real time: one thread steps the physics on the project's PeriodicSchedule (rt/schedule.h: an
// absolute CLOCK_MONOTONIC grid of 1 ms, stalls up to 20 ms caught up, longer ones skipped) and
// waits for frames between steps (ppoll on the bus fds until the next deadline). Lock-step:
// the thread blocks on the bus and advances only per SYNC; heartbeats also go out every 100 ms
// of wall time so a master's heartbeat watch is served while no SYNC flows.
// With `local:<path>`, a hub is created in-process when none listens at <path>.
#pragma once

#include <atomic>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>

#include "arm/can/bus_options.h"
#include "sim/pa10_plant.h"

namespace rtm::sim {

struct RunOptions {
  std::string scene_path;            // MJCF
  rtm::can::BusOptions buses;        // the arm's bus and the sensors' (the same when not set)
  bool lock_step = false;
  std::string profile_path;          // empty: zero operator wrench (unless stdin_wrench)
  bool stdin_wrench = false;         // read "fx fy fz [tx ty tz]" lines from stdin
  std::string log_path;              // CSV of the state per SYNC (empty: none)
  double duration_s = 0;             // stop after this much sim time (0: until stopped)
  double velocity_bandwidth_rad_s = ServoGains{}.velocity_bandwidth_rad_s;  // drive PI loop, -3 dB
  std::string surface = default_surface().name;  // a preset or a stiffness in N/m
  double friction = kDefaultFriction;  // Coulomb coefficient of the tool tip on the top
  bool quiet = false;
};

// A problem with the options (missing file, bad bus spec, bad profile): one line, for exit 1.
class RunError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Runs until `stop` becomes true (e.g. from a signal handler) or duration_s of sim time.
// Throws RunError (or the library's own errors, all with a clear message) on bad input.
void run_simulator(const RunOptions& options, const std::atomic<bool>& stop);

}  // namespace rtm::sim
