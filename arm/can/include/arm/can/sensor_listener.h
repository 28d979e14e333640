// SPDX-License-Identifier: Apache-2.0
// A passive listener for one force sensor node: no SYNC, no NMT, only reading.
//
// The sensor component in another process sits on the same bus as the master and reads the
// sensor's TPDO1 (force) and TPDO2 (torque) after each SYNC the master sends. It tracks the
// SYNC counter itself, so each wrench carries the counter and the (local, CLOCK_MONOTONIC) time
// of the SYNC it answers. It also watches the sensor's heartbeat and EMCY frames.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "arm/can/bus.h"
#include "arm/can/fault.h"
#include "arm/can/master_types.h"
#include "arm/can/protocol.h"
#include "arm/can/receive_thread.h"
#include "arm/can/wrench_assembly.h"
#include "rt/clock.h"

namespace rtm::can {

struct SensorListenerCounters {
  std::uint64_t wrenches = 0;          // complete force + torque pairs
  std::uint64_t syncs = 0;
  std::uint64_t malformed_frames = 0;
  std::uint64_t late_frames = 0;       // a half (force or torque) whose partner never came
  std::uint64_t emcy_frames = 0;
  std::uint64_t heartbeats = 0;        // heartbeat (and boot-up) frames of the node
};

class SensorListener {
 public:
  // Listens on `bus` for the sensor `node` (0x10 or 0x11; std::invalid_argument otherwise).
  // clock: what a heartbeat's silence is measured on (it must outlive the listener); a test's
  // manual clock passes the timeout in one step.
  SensorListener(std::unique_ptr<Bus> bus, std::uint8_t node, std::int64_t heartbeat_timeout_ns = 300'000'000,
                 const rtm::Clock& clock = rtm::monotonic_clock());
  SensorListener(std::string_view bus_spec, ForceSensor sensor, std::int64_t heartbeat_timeout_ns = 300'000'000,
                 const rtm::Clock& clock = rtm::monotonic_clock());
  ~SensorListener();  // stop()
  SensorListener(const SensorListener&) = delete;
  SensorListener& operator=(const SensorListener&) = delete;

  // Reads frames on the caller's thread for up to `timeout_ns`, returning as soon as a new
  // complete wrench arrived (true) or when the time is up (false). Not with start().
  bool poll(std::int64_t timeout_ns);

  // Or: a background thread (ReceiveThread) reads continuously; use latest()/wait_newer_than().
  void start();
  void stop();

  // The latest complete wrench (valid = false before the first one).
  Wrench latest() const;
  // Blocks until a wrench with sequence > `sequence` exists or `timeout_ns` passed (background
  // thread mode). Returns it, or nullopt on timeout.
  std::optional<Wrench> wait_newer_than(std::uint64_t sequence, std::int64_t timeout_ns);

  // The fault now, kind and sentence at one instant: emergency when the sensor sent an EMCY
  // with a non-zero code (cleared by an EMCY 0x0000, error reset), heartbeat_lost when its
  // heartbeat has been silent longer than heartbeat_timeout_ns after having been seen once
  // (cleared by the next heartbeat: the only kind that clears by itself), bus_error when the
  // background thread lost the bus; the first that applies, in that order from the last. May
  // allocate (the sentence).
  Fault fault() const;
  // fault()'s kind alone, allocating nothing: for a periodic caller that asks for the sentence
  // only when the kind is not none.
  FaultKind fault_kind() const;

  SensorListenerCounters counters() const;
  std::uint8_t node() const { return node_; }

 private:
  void handle(const can_frame& frame, std::int64_t received_ns);  // CLOCK_MONOTONIC
  FaultKind fault_kind_locked(std::int64_t now_ns) const;

  std::unique_ptr<Bus> bus_;
  std::uint8_t node_;
  std::int64_t heartbeat_timeout_ns_;
  const rtm::Clock& clock_;
  mutable std::mutex mutex_;
  std::condition_variable new_wrench_;
  Wrench latest_;
  SensorListenerCounters counters_;
  // Halves of the wrench being assembled for the current SYNC.
  std::uint8_t current_sync_counter_ = 0;
  std::int64_t current_sync_time_ns_ = 0;
  WrenchAssembly assembly_;
  std::uint16_t emcy_code_ = 0;
  std::optional<std::int64_t> last_heartbeat_ns_;  // on clock_
  std::string bus_error_;  // set when the background thread lost the bus
  ReceiveThread receiver_;  // last: stops before the state it writes goes
};

}  // namespace rtm::can
