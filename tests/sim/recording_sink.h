// SPDX-License-Identifier: Apache-2.0
// A FrameSink that keeps what the devices sent, with helpers to find frames by COB-ID.
#pragma once

#include <linux/can.h>

#include <vector>

#include "arm/can/protocol.h"
#include "sim/frame_sink.h"

namespace rtm::sim::testing {

class RecordingSink final : public FrameSink {
 public:
  void send(const can_frame& frame) override { frames.push_back(frame); }

  std::vector<can_frame> with_id(canid_t id) const {
    std::vector<can_frame> found;
    for (const auto& frame : frames)
      if (frame.can_id == id) found.push_back(frame);
    return found;
  }
  // Boot-up messages (heartbeats in state boot-up): one per node that powered on.
  int bootups() const {
    int count = 0;
    for (const auto& frame : frames)
      if (auto heartbeat = rtm::can::decode_heartbeat(frame);
          heartbeat.ok() && heartbeat->state == rtm::can::NmtState::boot_up)
        ++count;
    return count;
  }
  void clear() { frames.clear(); }

  std::vector<can_frame> frames;
};

}  // namespace rtm::sim::testing
