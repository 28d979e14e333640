// SPDX-License-Identifier: Apache-2.0
// A FrameSink that writes to a CAN bus (SocketCAN or the local hub), counting what the bus
// refused (transmit queue full).
#pragma once

#include <cstdint>

#include "arm/can/bus.h"
#include "sim/frame_sink.h"

namespace rtm::sim {

class BusSink final : public FrameSink {
 public:
  explicit BusSink(rtm::can::Bus& bus) : bus_(bus) {}
  void send(const can_frame& frame) override {
    if (!bus_.send(frame)) ++dropped_;
  }
  std::uint64_t dropped() const { return dropped_; }

 private:
  rtm::can::Bus& bus_;
  std::uint64_t dropped_ = 0;
};

}  // namespace rtm::sim
