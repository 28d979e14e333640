// SPDX-License-Identifier: Apache-2.0
// Where emulated CAN nodes put the frames they send.
//
// The device classes (DriveDevice, ForceSensorDevice) never touch a transport: they are fed
// frames and time and hand their replies to a FrameSink. pa10-sim's sink writes to an
// rtm::can::Bus; tests use a sink that records.
#pragma once

#include <linux/can.h>

namespace rtm::sim {

class FrameSink {
 public:
  virtual ~FrameSink() = default;
  // Sends one frame. Must not block for long (the simulator calls it from its stepping loop).
  virtual void send(const can_frame& frame) = 0;
  // Hands on what send() kept; a sink that sends at once keeps nothing. The simulator's loop
  // calls it before it waits.
  virtual void flush() {}
};

// Where a node cut off the bus sends: nowhere.
class NullSink final : public FrameSink {
 public:
  void send(const can_frame&) override {}
};

}  // namespace rtm::sim
