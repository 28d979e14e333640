// SPDX-License-Identifier: Apache-2.0
// A stage of a shared tick beside its components: receive() runs before them in each cycle, transmit() after
// them. The stage has cycles of its own (a thread that runs them when no tick does); take_over() makes them
// the tick's and hand_back() gives them back. The CAN master's SYNC cycle is one (arm/can/master.h): a tick
// that runs it receives the drives' answers, runs sensor -> controller -> actuator, and transmits the command
// with the next SYNC, all in one cycle on one thread.
#pragma once

#include <cstdint>

namespace rtm {

class TickStage {
 public:
  virtual ~TickStage() = default;

  // The stage's own cycles stop after the one in progress; returns the CLOCK_MONOTONIC
  // deadline [ns] of the cycle they would have run next (the tick's first, so none is lost or
  // doubled), 0 when none was running. Idempotent.
  virtual std::int64_t take_over() = 0;
  // The stage's own cycles run again, first at next_deadline_ns (0: now). No-op unless taken over.
  virtual void hand_back(std::int64_t next_deadline_ns) = 0;
  // The two halves of a cycle due at deadline_ns, from the tick's thread. false: the stage has
  // taken its cycles back (the tick fell silent for too long) and did nothing.
  virtual bool receive(std::int64_t deadline_ns) = 0;
  virtual bool transmit(std::int64_t deadline_ns) = 0;
};

}  // namespace rtm
