// SPDX-License-Identifier: Apache-2.0
#include "sim/drive_device.h"

#include "arm/can/protocol.h"

namespace rtm::sim {

namespace pc = rtm::can;

DriveDevice::DriveDevice(DriveConfig config) : config_(config), nmt_(config.node_id, config.heartbeat_period_ns) {}

void DriveDevice::power_on(std::int64_t now_ns, FrameSink& out) {
  nmt_.power_on(now_ns, wire(out));
  drive_.reset();
  mode_ = 0;
  rpdo_pending_ = false;
  pending_controlword_ = 0;
  pending_velocity_rad_s_ = 0;
  target_velocity_rad_s_ = 0;
  controlword_ = 0;
  syncs_without_rpdo_ = 0;
  tpdo_due_ = false;
}

void DriveDevice::on_frame(const can_frame& frame, std::int64_t now_ns, FrameSink& out) {
  if (!connected_) return;
  const pc::Classified kind = pc::classify(frame);
  switch (kind.type) {
    case pc::FrameType::nmt:
      handle_nmt(frame, now_ns, out);
      break;
    case pc::FrameType::sync:
      if (const auto sync = pc::decode_sync(frame); sync.ok()) handle_sync(sync->counter, now_ns, out);
      break;
    case pc::FrameType::drive_command:
      if (kind.node == config_.node_id) handle_rpdo(frame, now_ns);
      break;
    case pc::FrameType::sdo_request:
      if (kind.node == config_.node_id) handle_sdo(frame, out);
      break;
    default:
      break;
  }
}

void DriveDevice::handle_nmt(const can_frame& frame, std::int64_t now_ns, FrameSink& out) {
  const NmtNode::NmtEffect effect = nmt_.on_nmt(frame);
  if (effect == NmtNode::NmtEffect::reset) power_on(now_ns, out);
  // A node out of operational takes no PDOs: the drive must not keep moving on an old target.
  if (effect == NmtNode::NmtEffect::out_of_operational && drive_.follows_target_velocity())
    drive_.apply_controlword(pc::controlword::kSwitchOn);
}

void DriveDevice::handle_rpdo(const can_frame& frame, std::int64_t now_ns) {
  if (rpdos_to_lose_ > 0) {
    --rpdos_to_lose_;
    return;
  }
  if (!nmt_.is(pc::NmtState::operational)) return;
  const auto command = pc::decode_drive_command(frame);
  if (!command.ok()) return;
  last_rpdo_ns_ = now_ns;
  rpdo_pending_ = true;
  pending_controlword_ = command->controlword;
  pending_velocity_rad_s_ = command->target_velocity_rad_s;
}

void DriveDevice::handle_sync(std::uint8_t counter, std::int64_t now_ns, FrameSink& out) {
  ++syncs_seen_;
  last_sync_counter_ = counter;
  if (!nmt_.is(pc::NmtState::operational)) return;
  tpdo_due_ = true;
  if (rpdo_pending_) {
    rpdo_pending_ = false;
    syncs_without_rpdo_ = 0;
    const bool was_fault = in_fault();
    const bool was_enabled = drive_.follows_target_velocity();
    drive_.apply_controlword(pending_controlword_);
    controlword_ = pending_controlword_;
    if (was_fault && fault_persistent_) drive_.raise_fault();  // the reset does not take
    if (!was_enabled && drive_.follows_target_velocity()) last_rpdo_ns_ = now_ns;
    if (was_fault && !in_fault()) send_emcy(pc::emcy::kErrorReset, out);
    target_velocity_rad_s_ = pending_velocity_rad_s_;
    return;
  }
  // The PA10 firmware's command-loss guard: only a moving (enabled) drive can lose commands.
  if (!drive_.follows_target_velocity()) return;
  if (++syncs_without_rpdo_ >= config_.rpdo_timeout_syncs) enter_fault(pc::emcy::kRpdoTimeout, out);
}

void DriveDevice::enter_fault(std::uint16_t emcy_code, FrameSink& out) {
  drive_.raise_fault();
  target_velocity_rad_s_ = 0;
  syncs_without_rpdo_ = 0;
  send_emcy(emcy_code, out);
}

void DriveDevice::inject_fault(std::uint16_t emcy_code, FrameSink& out) {
  if (nmt_.powered()) enter_fault(emcy_code, out);
}

void DriveDevice::send_emcy(std::uint16_t code, FrameSink& out) {
  // Error register bit 0 (generic error) is set while an error is present.
  const std::uint8_t error_register = code == pc::emcy::kErrorReset ? 0x00 : 0x01;
  send_if_ok(pc::encode_emcy(config_.node_id, code, error_register), wire(out));
}

void DriveDevice::send_tpdo(const JointState& state, FrameSink& out) {
  if (!tpdo_due_) return;
  tpdo_due_ = false;
  if (!nmt_.is(pc::NmtState::operational)) return;
  if (tpdos_to_lose_ > 0) {
    --tpdos_to_lose_;
    return;
  }
  pc::DriveFeedback feedback{};
  feedback.drive = config_.node_id;
  feedback.statusword = drive_.statusword();
  feedback.position_rad = state.position_rad;
  feedback.velocity_rad_s = state.velocity_rad_s;
  send_if_ok(pc::encode_drive_feedback(feedback), wire(out));
}

void DriveDevice::tick(std::int64_t now_ns, FrameSink& out) {
  if (!nmt_.powered()) return;
  if (drive_.follows_target_velocity() && config_.rpdo_silence_timeout_ns > 0 &&
      now_ns - last_rpdo_ns_ > config_.rpdo_silence_timeout_ns)
    enter_fault(pc::emcy::kRpdoTimeout, out);
  nmt_.tick(now_ns, wire(out));
}

JointCommand DriveDevice::command() const {
  const bool moving = drive_.follows_target_velocity() &&
                      nmt_.is(pc::NmtState::operational);
  if (!moving) return {};
  return {JointCommand::Mode::velocity, target_velocity_rad_s_};
}

void DriveDevice::handle_sdo(const can_frame& frame, FrameSink& out) {
  // on_frame() returns before this when disconnected: `out` reaches the bus.
  auto exchange = nmt_.sdo_exchange(frame);
  if (!exchange) return;
  const pc::SdoRequest* request = &exchange->request;
  pc::SdoResponse& response = exchange->response;
  auto abort = [&](std::uint32_t code) {
    response.kind = pc::SdoResponseKind::abort;
    response.data = code;
    response.data_size = 0;
    send_if_ok(pc::encode_sdo_response(response), out);
  };
  auto upload = [&](std::uint32_t value, std::uint8_t size) {
    response.kind = pc::SdoResponseKind::upload_data;
    response.data = value;
    response.data_size = size;
    send_if_ok(pc::encode_sdo_response(response), out);
  };
  if (request->subindex != 0) return abort(pc::sdo::kAbortNoObject);

  if (request->kind == pc::SdoRequestKind::download) {
    switch (request->index) {
      case pc::object::kModesOfOperation: {
        if (request->data_size != 1) return abort(pc::sdo::kAbortLengthMismatch);
        if (!nmt_.is(pc::NmtState::pre_operational))
          return abort(pc::sdo::kAbortWrongState);
        const auto mode = static_cast<std::int8_t>(request->data & 0xFF);
        if (mode != pc::object::kCyclicSynchronousVelocityMode || !config_.offers_csv_mode)
          return abort(pc::sdo::kAbortValueRange);
        mode_ = mode;
        break;
      }
      case 0x1017: {
        if (request->data_size != 2) return abort(pc::sdo::kAbortLengthMismatch);
        if (request->data == 0) return abort(pc::sdo::kAbortValueRange);
        nmt_.set_heartbeat_period_ns(static_cast<std::int64_t>(request->data) * 1'000'000);
        break;
      }
      case pc::object::kModesOfOperationDisplay:
      case pc::object::kStatusword:
      case pc::object::kPositionActual:
      case pc::object::kVelocityActual:
        return abort(pc::sdo::kAbortReadOnly);
      default:
        return abort(pc::sdo::kAbortNoObject);
    }
    response.kind = pc::SdoResponseKind::download_ack;
    response.data = 0;
    response.data_size = 0;
    send_if_ok(pc::encode_sdo_response(response), out);
    return;
  }

  switch (request->index) {
    case pc::object::kModesOfOperation:
    case pc::object::kModesOfOperationDisplay:
      return upload(static_cast<std::uint8_t>(mode_), 1);
    case pc::object::kStatusword:
      return upload(drive_.statusword(), 2);
    case 0x1017:
      return upload(static_cast<std::uint32_t>(nmt_.heartbeat_period_ns() / 1'000'000), 2);
    case pc::object::kPositionActual:
    case pc::object::kVelocityActual:
      // Served by TPDO1 only: the device class does not hold the joint state between SYNCs.
      return abort(pc::sdo::kAbortUnsupportedCommand);
    default:
      return abort(pc::sdo::kAbortNoObject);
  }
}

}  // namespace rtm::sim
