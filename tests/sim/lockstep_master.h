// SPDX-License-Identifier: Apache-2.0
// A master in frames for the simulator's lock-step tests: feeds any node that takes
// on_frame(frame, sink) (the rig on a kinematic plant, the MuJoCo simulator) the frames a
// CANopen master sends, and reads back what the drives answered.
#pragma once

#include "arm/can/protocol.h"
#include "recording_sink.h"

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <optional>

namespace rtm::sim::testing {

template <class Node>
class LockStepMaster {
 public:
  LockStepMaster(Node& node, RecordingSink& out) : node_(node), out_(out) {}

  void feed(const rtm::can::Result<can_frame>& frame) {
    ASSERT_TRUE(frame.ok());
    node_.on_frame(*frame, out_);
  }
  // One master cycle: an RPDO to every drive, then SYNC.
  void cycle(std::uint16_t controlword, const std::array<double, 7>& velocity_rad_s = {}) {
    namespace pc = rtm::can;
    for (int j = 0; j < 7; ++j)
      feed(pc::encode_drive_command({pc::drive_node(j), controlword, velocity_rad_s[static_cast<std::size_t>(j)]}));
    sync_only();
  }
  // The same velocity for every joint.
  void cycle_all(std::uint16_t controlword, double velocity_rad_s) {
    std::array<double, 7> v{};
    v.fill(velocity_rad_s);
    cycle(controlword, v);
  }
  void sync_only() {
    counter_ = rtm::can::next_sync_counter(counter_);
    feed(rtm::can::encode_sync(counter_));
  }
  // Mode 9 by SDO to every drive, NMT start, then the CiA 402 enable sequence.
  void start_up() {
    namespace pc = rtm::can;
    for (int j = 0; j < 7; ++j)
      feed(pc::encode_sdo_request({pc::drive_node(j), pc::SdoRequestKind::download, pc::object::kModesOfOperation, 0, 9, 1}));
    feed(pc::encode_nmt(pc::NmtCommand::start, 0));
    for (std::uint16_t cw : {pc::controlword::kShutdown, pc::controlword::kSwitchOn, pc::controlword::kEnableOperation})
      cycle(cw);
  }
  std::optional<rtm::can::DriveFeedback> last_feedback(int joint) const {
    const auto frames = out_.with_id(rtm::can::cob::kTpdo1Base + rtm::can::drive_node(joint));
    if (frames.empty()) return std::nullopt;
    return *rtm::can::decode_drive_feedback(frames.back());
  }
  std::uint8_t counter() const { return counter_; }

 private:
  Node& node_;
  RecordingSink& out_;
  std::uint8_t counter_ = 0;
};

}  // namespace rtm::sim::testing
