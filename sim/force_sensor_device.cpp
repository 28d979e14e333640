// SPDX-License-Identifier: Apache-2.0
#include "sim/force_sensor_device.h"

#include <cmath>
#include <limits>

#include "arm/can/protocol.h"

namespace rtm::sim {

namespace pc = rtm::can;

namespace {

std::int16_t saturate_counts(double value, double unit, bool& saturated) {
  const double counts = std::round(value / unit);
  constexpr double kMax = std::numeric_limits<std::int16_t>::max();
  constexpr double kMin = std::numeric_limits<std::int16_t>::min();
  if (!(counts <= kMax)) {  // also catches NaN: a broken reading is reported as overload
    saturated = true;
    return std::isnan(counts) ? 0 : std::numeric_limits<std::int16_t>::max();
  }
  if (counts < kMin) {
    saturated = true;
    return std::numeric_limits<std::int16_t>::min();
  }
  return static_cast<std::int16_t>(counts);
}

}  // namespace

ForceSensorDevice::ForceSensorDevice(ForceSensorConfig config)
    : config_(config), nmt_(config.node_id, config.heartbeat_period_ns) {}

void ForceSensorDevice::power_on(std::int64_t now_ns, FrameSink& out) {
  nmt_.power_on(now_ns, wire(out));
  tpdo_due_ = false;
}

void ForceSensorDevice::on_frame(const can_frame& frame, std::int64_t now_ns, FrameSink& out) {
  if (!connected_) return;
  const pc::Classified kind = pc::classify(frame);
  if (kind.type == pc::FrameType::sync) {
    const auto sync = pc::decode_sync(frame);
    if (!sync.ok()) return;
    last_sync_counter_ = sync->counter;
    if (nmt_.is(pc::NmtState::operational)) tpdo_due_ = true;
    return;
  }
  if (kind.type == pc::FrameType::sdo_request && kind.node == config_.node_id) {
    handle_sdo(frame, out);
    return;
  }
  if (kind.type != pc::FrameType::nmt) return;
  const NmtNode::NmtEffect effect = nmt_.on_nmt(frame);
  if (effect == NmtNode::NmtEffect::reset) power_on(now_ns, out);
  if (effect == NmtNode::NmtEffect::out_of_operational) tpdo_due_ = false;
}

ForceSensorDevice::Counts ForceSensorDevice::to_counts(const Wrench& raw) const {
  Counts counts{};
  counts.saturated = false;
  for (int i = 0; i < 3; ++i) {
    counts.force[i] = saturate_counts(raw.force_N[i] - offset_.force_N[i], pc::kForceUnit_N,
                                      counts.saturated);
    counts.torque[i] = saturate_counts(raw.torque_Nm[i] - offset_.torque_Nm[i],
                                       pc::kTorqueUnit_Nm, counts.saturated);
  }
  return counts;
}

void ForceSensorDevice::send_tpdo(const Wrench& raw, FrameSink& out) {
  if (!tpdo_due_) return;
  tpdo_due_ = false;
  if (!nmt_.is(pc::NmtState::operational)) return;
  const Counts counts = to_counts(raw);
  pc::SensorForce force{};
  pc::SensorTorque torque{};
  force.node = torque.node = config_.node_id;
  for (int i = 0; i < 3; ++i) {
    force.force_N[i] = counts.force[i] * pc::kForceUnit_N;
    torque.torque_Nm[i] = counts.torque[i] * pc::kTorqueUnit_Nm;
  }
  send_if_ok(pc::encode_sensor_force(force), wire(out));
  send_if_ok(pc::encode_sensor_torque(torque), wire(out));
  if (counts.saturated != overload_reported_) {
    overload_reported_ = counts.saturated;
    send_emcy(counts.saturated ? pc::emcy::kSensorFault : pc::emcy::kErrorReset, out);
  }
}

void ForceSensorDevice::tick(std::int64_t now_ns, FrameSink& out) { nmt_.tick(now_ns, wire(out)); }

void ForceSensorDevice::add_tare_sample(const Wrench& raw) {
  if (tared()) return;
  for (int i = 0; i < 3; ++i) {
    tare_sum_.force_N[i] += raw.force_N[i];
    tare_sum_.torque_Nm[i] += raw.torque_Nm[i];
  }
  ++tare_count_;
  for (int i = 0; i < 3; ++i) {
    offset_.force_N[i] = tare_sum_.force_N[i] / tare_count_;
    offset_.torque_Nm[i] = tare_sum_.torque_Nm[i] / tare_count_;
  }
}

void ForceSensorDevice::send_emcy(std::uint16_t code, FrameSink& out) {
  const std::uint8_t error_register = code == pc::emcy::kErrorReset ? 0x00 : 0x01;
  send_if_ok(pc::encode_emcy(config_.node_id, code, error_register), wire(out));
}

void ForceSensorDevice::handle_sdo(const can_frame& frame, FrameSink& out) {
  auto exchange = nmt_.sdo_exchange(frame);
  if (!exchange) return;
  const pc::SdoRequest* request = &exchange->request;
  pc::SdoResponse& response = exchange->response;
  if (request->kind == pc::SdoRequestKind::upload && request->index == 0x1017 &&
      request->subindex == 0) {
    response.kind = pc::SdoResponseKind::upload_data;
    response.data = static_cast<std::uint32_t>(nmt_.heartbeat_period_ns() / 1'000'000);
    response.data_size = 2;
  } else {
    response.kind = pc::SdoResponseKind::abort;
    response.data = request->kind == pc::SdoRequestKind::download && request->index == 0x1017
                        ? pc::sdo::kAbortReadOnly
                        : pc::sdo::kAbortNoObject;
  }
  send_if_ok(pc::encode_sdo_response(response), out);
}

}  // namespace rtm::sim
