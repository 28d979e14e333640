// SPDX-License-Identifier: Apache-2.0
// Lock-step on a local bus instead of sleeping: a test that sends frames and then steps a
// master waits until they are in every other endpoint's queue (Bus::fence), so the step reads
// them however loaded the machine is.
//
//   intruder->send(frame);
//   ASSERT_TRUE(delivered(*intruder));  // the next step() of the master reads the frame
//
//   auto probe = open_bus(rig.spec);    // before the nodes send
//   rig.nodes->inject_fault(drive_node(3), emcy::kRpdoTimeout);
//   ASSERT_TRUE(seen_and_delivered(*probe, cob::kEmcyBase + drive_node(3)));
//
//   master.transmit_cycle();            // a SYNC
//   ASSERT_TRUE(all_seen_and_delivered(*probe, sync_answers()));  // the next receive has them
#pragma once

#include <chrono>
#include <cstdint>
#include <vector>

#include "arm/can/bus.h"
#include "arm/can/protocol.h"

namespace rtm::can::testing {

// Bounds how long a broken build waits; no assertion is about speed.
inline constexpr std::int64_t kLockStepBound_ns = 20'000'000'000;

// Every frame sender sent so far is queued at every other endpoint.
inline bool delivered(Bus& sender) { return sender.fence(kLockStepBound_ns); }

// probe received a frame with each of these ids (other endpoints sent them), and every
// endpoint has them queued: the hub had handed them on to all of them before it answered
// probe's fence, which it read in a later round. Other frames at probe are dropped.
inline bool all_seen_and_delivered(Bus& probe, std::vector<canid_t> ids) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::nanoseconds(kLockStepBound_ns);
  can_frame frame{};
  while (!ids.empty()) {
    const auto left = std::chrono::duration_cast<std::chrono::nanoseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0 || !probe.receive(frame, left.count())) return false;
    std::erase(ids, frame.can_id);
  }
  return probe.fence(kLockStepBound_ns);
}

inline bool seen_and_delivered(Bus& probe, canid_t id) { return all_seen_and_delivered(probe, {id}); }

// What the PA10's nodes answer to one SYNC: every drive's TPDO1 (feedback) and each force
// sensor's TPDO1 (force) and TPDO2 (torque).
inline std::vector<canid_t> sync_answers() {
  std::vector<canid_t> ids;
  for (int j = 0; j < kDriveCount; ++j) ids.push_back(cob::kTpdo1Base + drive_node(j));
  for (const std::uint8_t sensor : {kWristSensorNode, kJoystickSensorNode}) {
    ids.push_back(cob::kTpdo1Base + sensor);
    ids.push_back(cob::kTpdo2Base + sensor);
  }
  return ids;
}

}  // namespace rtm::can::testing
