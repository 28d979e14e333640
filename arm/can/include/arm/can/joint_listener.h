// SPDX-License-Identifier: Apache-2.0
// A passive listener for the drives' joint feedback: no SYNC, no NMT, only reading.
//
// Every drive broadcasts its TPDO1 (statusword, position, velocity) after each SYNC the
// master sends, so any process on the bus can follow the arm's joint state without being its
// master (the sensor component rotates the wrist wrench with it). Like SensorListener it
// tracks the SYNC counter itself: the joint state carries the counter and the (local,
// CLOCK_MONOTONIC) time of the SYNC it answers, and is complete when all seven drives
// answered that SYNC - the master's own JointState, as heard from the side.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <string_view>

#include "arm/can/bus.h"
#include "arm/can/joint_assembly.h"
#include "arm/can/master_types.h"
#include "arm/can/protocol.h"
#include "arm/can/receive_thread.h"

namespace rtm::can {

struct JointListenerCounters {
  std::uint64_t syncs = 0;
  std::uint64_t feedback_frames = 0;   // drive TPDO1s read
  std::uint64_t complete_syncs = 0;    // SYNCs every drive answered
  std::uint64_t incomplete_syncs = 0;  // SYNCs not every drive answered before the next one
  std::uint64_t malformed_frames = 0;
};

class JointListener {
 public:
  // Listens on `bus` (any filters that let SYNC and the drives' TPDO1 through).
  explicit JointListener(std::unique_ptr<Bus> bus);
  // Opens `bus_spec` with filters for SYNC and the seven drive TPDO1s (filters()). Throws
  // BusError naming the spec.
  explicit JointListener(std::string_view bus_spec);
  ~JointListener();  // stop()
  JointListener(const JointListener&) = delete;
  JointListener& operator=(const JointListener&) = delete;

  // A background thread reads the bus from start() to stop().
  void start();
  void stop();

  // The joint state as of the last SYNC every drive answered, or - when one stayed silent -
  // as of the next SYNC, with complete = false and that drive's last values. cycle counts the
  // SYNCs heard from 1, sync_time_ns is when the SYNC was received; sync_counter = 0 until
  // the first one is published.
  JointState latest() const;

  // none while the bus works; after a transport failure (the thread then stops reading)
  // bus_error with the reason, naming the bus: "joint listener: CAN bus 'local:/tmp/pa10.bus':
  // the hub closed the connection".
  Fault fault() const;
  FaultKind fault_kind() const;  // fault()'s kind alone, allocating nothing

  JointListenerCounters counters() const;

  // SYNC and the drives' TPDO1s: all this listener reads.
  static std::span<const FrameFilter> filters();

 private:
  void handle(const can_frame& frame, std::int64_t received_ns);  // CLOCK_MONOTONIC
  void open_window(std::uint8_t sync_counter, std::int64_t received_ns);
  void publish();  // the window as it is now

  std::unique_ptr<Bus> bus_;
  mutable std::mutex mutex_;
  JointState latest_;
  JointListenerCounters counters_;
  // The answers to the SYNC heard last (its window).
  std::uint8_t window_sync_counter_ = 0;
  std::int64_t window_sync_time_ns_ = 0;
  JointAssembly joints_;
  bool window_published_ = true;  // no window before the first SYNC
  std::string bus_error_;         // set when the background thread lost the bus
  ReceiveThread receiver_;        // last: stops before the state it writes goes
};

}  // namespace rtm::can
