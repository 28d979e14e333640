// SPDX-License-Identifier: Apache-2.0
// What every emulated CANopen node of pa10-sim shares (CiA 301): the NMT slave state machine
// and the heartbeat producer. DriveDevice and ForceSensorDevice each own one and add what their
// node does on top (a stopped drive drops out of operation enabled, a stopped sensor stops
// reporting, ...).
#pragma once

#include <linux/can.h>

#include <cstdint>
#include <optional>

#include "arm/can/protocol.h"
#include "sim/frame_sink.h"

namespace rtm::sim {

// Sends an encoded frame. Encoders refuse only out-of-range node ids or NaN, impossible here
// by construction, so a refusal is not sent rather than thrown into the stepping loop.
inline void send_if_ok(const rtm::can::Result<can_frame>& frame, FrameSink& out) {
  if (frame.ok()) out.send(*frame);
}

class NmtNode {
 public:
  NmtNode(std::uint8_t node_id, std::int64_t heartbeat_period_ns)
      : node_id_(node_id), heartbeat_period_ns_(heartbeat_period_ns) {}

  // Power on or reset: sends the boot-up message (0x700+id, [0x00]) and enters
  // pre-operational; the first heartbeat follows one period later.
  void power_on(std::int64_t now_ns, FrameSink& out) {
    state_ = rtm::can::NmtState::boot_up;
    send_if_ok(rtm::can::encode_heartbeat(node_id_, state_), out);
    state_ = rtm::can::NmtState::pre_operational;
    next_heartbeat_ns_ = now_ns + heartbeat_period_ns_;
  }

  // An NMT frame: when it is well formed and addressed to this node (or to all), applies
  // start / stop / enter pre-operational and says what the device must add of its own (a
  // reset is left to the device's power_on()).
  enum class NmtEffect {
    none,                // not for this node, malformed, or start (now operational)
    out_of_operational,  // stop or enter pre-operational: the node takes no PDOs now
    reset,               // reset node or communication: the device powers on again
  };
  NmtEffect on_nmt(const can_frame& frame) {
    const auto nmt = rtm::can::decode_nmt(frame);
    if (!nmt.ok() || (nmt->node != rtm::can::kNmtAllNodes && nmt->node != node_id_)) return NmtEffect::none;
    switch (nmt->command) {
      case rtm::can::NmtCommand::start: state_ = rtm::can::NmtState::operational; return NmtEffect::none;
      case rtm::can::NmtCommand::stop: state_ = rtm::can::NmtState::stopped; return NmtEffect::out_of_operational;
      case rtm::can::NmtCommand::enter_pre_operational:
        state_ = rtm::can::NmtState::pre_operational;
        return NmtEffect::out_of_operational;
      case rtm::can::NmtCommand::reset_node:
      case rtm::can::NmtCommand::reset_communication: return NmtEffect::reset;
    }
    return NmtEffect::none;
  }

  // Advances the node's clock: the heartbeat when its period has elapsed (after a clock jump
  // of several periods one heartbeat, no burst). Nothing before power_on().
  void tick(std::int64_t now_ns, FrameSink& out) {
    if (!powered() || now_ns < next_heartbeat_ns_) return;
    send_heartbeat(out);
    while (next_heartbeat_ns_ <= now_ns) next_heartbeat_ns_ += heartbeat_period_ns_;
  }

  // An SDO request this node serves now (CiA 301: in pre-operational and operational, not in
  // stopped), with its response addressed to it (node, index, subindex); nullopt otherwise.
  struct SdoExchange {
    rtm::can::SdoRequest request;
    rtm::can::SdoResponse response;
  };
  std::optional<SdoExchange> sdo_exchange(const can_frame& frame) const {
    const auto request = rtm::can::decode_sdo_request(frame);
    if (!request.ok() || is(rtm::can::NmtState::stopped)) return std::nullopt;
    rtm::can::SdoResponse response{};
    response.node = node_id_;
    response.index = request->index;
    response.subindex = request->subindex;
    return SdoExchange{*request, response};
  }

  void send_heartbeat(FrameSink& out) const {
    if (powered()) send_if_ok(rtm::can::encode_heartbeat(node_id_, state_), out);
  }

  bool powered() const { return state_ != rtm::can::NmtState::boot_up; }
  bool is(rtm::can::NmtState state) const { return state_ == state; }
  std::uint8_t state() const { return static_cast<std::uint8_t>(state_); }
  std::uint8_t node_id() const { return node_id_; }
  std::int64_t heartbeat_period_ns() const { return heartbeat_period_ns_; }
  void set_heartbeat_period_ns(std::int64_t period_ns) { heartbeat_period_ns_ = period_ns; }  // 0x1017

 private:
  std::uint8_t node_id_;
  std::int64_t heartbeat_period_ns_;
  rtm::can::NmtState state_ = rtm::can::NmtState::boot_up;
  std::int64_t next_heartbeat_ns_ = 0;
};

}  // namespace rtm::sim
