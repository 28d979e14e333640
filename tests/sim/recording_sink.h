// A FrameSink that keeps what the devices sent, with helpers to find frames by COB-ID.
#pragma once

#include <linux/can.h>

#include <vector>

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
  void clear() { frames.clear(); }

  std::vector<can_frame> frames;
};

}  // namespace rtm::sim::testing
