// SPDX-License-Identifier: Apache-2.0
// A FrameSink that writes to a CAN bus (SocketCAN or the local hub), counting what the bus
// refused (transmit queue full). Frames are kept until flush() (or until kBatch are kept) and
// then leave in one send_batch: the replies to one SYNC reach the bus, and the hub's next
// round, together, for one system call where a send each once cost one per frame.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "arm/can/bus.h"
#include "sim/frame_sink.h"

namespace rtm::sim {

class BusSink final : public FrameSink {
 public:
  static constexpr std::size_t kBatch = 32;

  explicit BusSink(rtm::can::Bus& bus) : bus_(bus) {}
  ~BusSink() override {
    try {
      flush();
    } catch (const rtm::can::BusError&) {
      // the bus went away: nobody is there to hear the last frames
    }
  }
  BusSink(const BusSink&) = delete;
  BusSink& operator=(const BusSink&) = delete;

  void send(const can_frame& frame) override {
    if (count_ == pending_.size()) flush();
    pending_[count_++] = frame;
  }
  // Sends what was kept, in order; a frame the bus refused is counted as dropped. Throws
  // rtm::can::BusError as the bus does (the frames are gone then).
  void flush() override {
    const std::size_t count = count_;
    count_ = 0;
    if (count > 0) dropped_ += count - bus_.send_batch(std::span(pending_.data(), count));
  }
  std::uint64_t dropped() const { return dropped_; }

 private:
  rtm::can::Bus& bus_;
  std::array<can_frame, kBatch> pending_{};
  std::size_t count_ = 0;
  std::uint64_t dropped_ = 0;
};

}  // namespace rtm::sim
