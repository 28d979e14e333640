// SPDX-License-Identifier: Apache-2.0
// The receive loop of the passive listeners (SensorListener, JointListener): one thread that
// reads one bus and hands every frame, with the CLOCK_MONOTONIC time it was read, to the
// listener. A BusError ends the loop and goes to the listener's error handler, never out of
// the thread; the listener reports it through its fault().
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <thread>

#include "arm/can/bus.h"

namespace rtm::can {

class ReceiveThread {
 public:
  using FrameHandler = std::function<void(const can_frame& frame, std::int64_t received_ns)>;
  using ErrorHandler = std::function<void(const BusError& error)>;

  // The receive timeout: how long stop() waits for the thread at most (plus one handler).
  static constexpr std::int64_t kWakeUp_ns = 20'000'000;

  ReceiveThread() = default;
  ~ReceiveThread();  // stop()
  ReceiveThread(const ReceiveThread&) = delete;
  ReceiveThread& operator=(const ReceiveThread&) = delete;

  // Starts reading `bus`, which must outlive the thread. Does nothing when already started.
  void start(Bus& bus, FrameHandler on_frame, ErrorHandler on_error);
  // Stops and joins the thread. Idempotent.
  void stop();
  // Between start() and stop(), also after a bus error ended the loop.
  bool started() const { return started_.load(); }

 private:
  std::atomic<bool> started_{false};
  std::thread thread_;
};

}  // namespace rtm::can
