// SPDX-License-Identifier: Apache-2.0
#include "arm/can/receive_thread.h"

#include "rt/clock.h"
#include "rt/thread.h"

#include <utility>

namespace rtm::can {

ReceiveThread::~ReceiveThread() { stop(); }

void ReceiveThread::start(Bus& bus, FrameHandler on_frame, ErrorHandler on_error) {
  if (started_.exchange(true)) return;
  thread_ = std::thread([this, &bus, on_frame = std::move(on_frame), on_error = std::move(on_error)] {
    // On the real-time path: a sensor's frames reach its loop through this thread, so it runs
    // at the loop's priority when the process has one (rtm::path_thread_priority()).
    if (const int priority = rtm::path_thread_priority(); priority > 0) {
      rtm::ThreadSettings settings;
      settings.name = "can-receive";
      settings.fifo_priority = priority;
      rtm::apply_thread_settings(settings);
    } else {
      rtm::set_thread_name("can-receive");
    }
    can_frame frame{};
    while (started_.load()) {
      try {
        if (bus.receive(frame, kWakeUp_ns)) on_frame(frame, monotonic_ns());
      } catch (const BusError& e) {
        on_error(e);
        return;
      }
    }
  });
}

void ReceiveThread::stop() {
  if (!started_.exchange(false)) return;
  if (thread_.joinable()) thread_.join();
}

}  // namespace rtm::can
