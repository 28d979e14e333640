// SPDX-License-Identifier: Apache-2.0
#include "arm/can/protocol.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <optional>
#include <stdexcept>

namespace rtm::can {

namespace {

// ---- little-endian helpers (the payload byte order is fixed, the host's is not) -----------

void put_u16(std::uint8_t* p, std::uint16_t v) {
  p[0] = static_cast<std::uint8_t>(v);
  p[1] = static_cast<std::uint8_t>(v >> 8);
}
void put_u32(std::uint8_t* p, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
std::uint16_t get_u16(const std::uint8_t* p) {
  return static_cast<std::uint16_t>(p[0] | (p[1] << 8));
}
std::uint32_t get_u32(const std::uint8_t* p) {
  std::uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= static_cast<std::uint32_t>(p[i]) << (8 * i);
  return v;
}

// Rounds value/unit to the nearest integer of type Int, clamping at its range. NaN is
// rejected by the callers before this.
template <class Int>
Int scale_saturating(double value, double unit) {
  const double scaled = std::round(value / unit);  // half away from zero, as documented
  constexpr double lo = static_cast<double>(std::numeric_limits<Int>::min());
  constexpr double hi = static_cast<double>(std::numeric_limits<Int>::max());
  if (!(scaled > lo)) return std::numeric_limits<Int>::min();
  if (!(scaled < hi)) return std::numeric_limits<Int>::max();
  return static_cast<Int>(scaled);
}

can_frame make_frame(canid_t id, std::uint8_t dlc) {
  can_frame f{};
  f.can_id = id;
  f.can_dlc = dlc;
  return f;
}

bool is_classic(const can_frame& f) {
  return (f.can_id & (CAN_EFF_FLAG | CAN_RTR_FLAG | CAN_ERR_FLAG)) == 0;
}

// Checks format, id in [base + first, base + last] and DLC; on success stores the node.
std::optional<CodecError> check(const can_frame& f, canid_t base, unsigned first_node,
                                unsigned last_node, std::uint8_t dlc, std::uint8_t& node) {
  if (!is_classic(f)) return CodecError::not_classic_frame;
  const canid_t id = f.can_id & CAN_SFF_MASK;
  if (id < base + first_node || id > base + last_node) return CodecError::wrong_cob_id;
  if (f.can_dlc != dlc) return CodecError::wrong_dlc;
  node = static_cast<std::uint8_t>(id - base);
  return std::nullopt;
}

bool valid_node(unsigned node) { return node >= 1 && node <= 127; }

bool valid_nmt_state(std::uint8_t s) {
  return s == 0x00 || s == 0x04 || s == 0x05 || s == 0x7F;
}
bool valid_nmt_command(std::uint8_t c) {
  return c == 0x01 || c == 0x02 || c == 0x80 || c == 0x81 || c == 0x82;
}

std::optional<std::uint8_t> sdo_size_of(std::uint8_t command, std::uint8_t one, std::uint8_t two,
                                        std::uint8_t four) {
  if (command == one) return 1;
  if (command == two) return 2;
  if (command == four) return 4;
  return std::nullopt;
}

bool fits(std::uint32_t data, std::uint8_t size) {
  return size == 4 || (data >> (8 * size)) == 0;
}

}  // namespace

// ---- names -------------------------------------------------------------------------------

std::string_view joint_name(int joint_index) {
  static constexpr std::array<std::string_view, kDriveCount> names = {"S1", "S2", "S3", "E1",
                                                                      "E2", "W1", "W2"};
  if (joint_index < 0 || joint_index >= kDriveCount) return "?";
  return names[static_cast<std::size_t>(joint_index)];
}

std::string node_description(unsigned node) {
  char text[48];
  if (is_drive_node(node)) {
    std::snprintf(text, sizeof text, "drive %u (%s)", node,
                  joint_name(static_cast<int>(node) - kFirstDriveNode).data());
  } else if (node == kWristSensorNode) {
    std::snprintf(text, sizeof text, "wrist sensor 0x%02x", node);
  } else if (node == kJoystickSensorNode) {
    std::snprintf(text, sizeof text, "joystick sensor 0x%02x", node);
  } else {
    std::snprintf(text, sizeof text, "node 0x%02x", node);
  }
  return text;
}

std::string_view to_string(NmtState state) {
  switch (state) {
    case NmtState::boot_up: return "boot-up";
    case NmtState::stopped: return "stopped";
    case NmtState::operational: return "operational";
    case NmtState::pre_operational: return "pre-operational";
  }
  return "invalid";
}

std::string_view emcy_description(std::uint16_t error_code) {
  switch (error_code) {
    case emcy::kErrorReset: return "error reset";
    case emcy::kRpdoTimeout: return "RPDO timeout (command loss)";
    case emcy::kHeartbeat: return "heartbeat / life guard error";
    case emcy::kSensorFault: return "sensor fault";
    case emcy::kDeviceHardware: return "device hardware";
    default: return "unknown error code";
  }
}

std::string_view to_string(CodecError error) {
  switch (error) {
    case CodecError::not_classic_frame: return "not a classic data frame (extended id, RTR or error frame)";
    case CodecError::wrong_cob_id: return "wrong COB-ID for this frame";
    case CodecError::wrong_dlc: return "wrong data length (DLC)";
    case CodecError::out_of_range: return "field out of range";
    case CodecError::unknown_command: return "unknown command byte";
    case CodecError::not_a_number: return "value is NaN";
  }
  return "invalid error";
}

void throw_bad_result_access(CodecError error) {
  throw std::logic_error("rtm::can::Result::value() on an error: " + std::string(to_string(error)));
}

std::string_view to_string(FrameType type) {
  switch (type) {
    case FrameType::nmt: return "NMT";
    case FrameType::sync: return "SYNC";
    case FrameType::emcy: return "EMCY";
    case FrameType::drive_feedback: return "drive TPDO1";
    case FrameType::sensor_force: return "sensor TPDO1";
    case FrameType::drive_command: return "drive RPDO1";
    case FrameType::sensor_torque: return "sensor TPDO2";
    case FrameType::sdo_response: return "SDO response";
    case FrameType::sdo_request: return "SDO request";
    case FrameType::heartbeat: return "heartbeat";
    case FrameType::unknown: return "unknown";
  }
  return "invalid";
}

// ---- encoders ----------------------------------------------------------------------------

Result<can_frame> encode_nmt(NmtCommand command, std::uint8_t node) {
  if (node > 127) return CodecError::wrong_cob_id;
  if (!valid_nmt_command(static_cast<std::uint8_t>(command))) return CodecError::unknown_command;
  can_frame f = make_frame(cob::kNmt, 2);
  f.data[0] = static_cast<std::uint8_t>(command);
  f.data[1] = node;
  return f;
}

Result<can_frame> encode_sync(std::uint8_t counter) {
  if (counter < 1 || counter > kSyncCounterMax) return CodecError::out_of_range;
  can_frame f = make_frame(cob::kSync, 1);
  f.data[0] = counter;
  return f;
}

Result<can_frame> encode_heartbeat(std::uint8_t node, NmtState state) {
  if (!valid_node(node)) return CodecError::wrong_cob_id;
  if (!valid_nmt_state(static_cast<std::uint8_t>(state))) return CodecError::out_of_range;
  can_frame f = make_frame(cob::kHeartbeatBase + node, 1);
  f.data[0] = static_cast<std::uint8_t>(state);
  return f;
}

Result<can_frame> encode_emcy(std::uint8_t node, std::uint16_t error_code,
                              std::uint8_t error_register) {
  if (!valid_node(node)) return CodecError::wrong_cob_id;
  can_frame f = make_frame(cob::kEmcyBase + node, 8);
  put_u16(f.data, error_code);
  f.data[2] = error_register;
  return f;
}

Result<can_frame> encode_drive_command(const DriveCommand& command) {
  if (!is_drive_node(command.drive)) return CodecError::wrong_cob_id;
  if (std::isnan(command.target_velocity_rad_s)) return CodecError::not_a_number;
  can_frame f = make_frame(cob::kRpdo1Base + command.drive, 6);
  put_u16(f.data, command.controlword);
  put_u32(f.data + 2, static_cast<std::uint32_t>(scale_saturating<std::int32_t>(
                          command.target_velocity_rad_s, kTargetVelocityUnit_rad_s)));
  return f;
}

Result<can_frame> encode_drive_feedback(const DriveFeedback& feedback) {
  if (!is_drive_node(feedback.drive)) return CodecError::wrong_cob_id;
  if (std::isnan(feedback.position_rad) || std::isnan(feedback.velocity_rad_s)) {
    return CodecError::not_a_number;
  }
  can_frame f = make_frame(cob::kTpdo1Base + feedback.drive, 8);
  put_u16(f.data, feedback.statusword);
  put_u32(f.data + 2, static_cast<std::uint32_t>(
                          scale_saturating<std::int32_t>(feedback.position_rad, kPositionUnit_rad)));
  put_u16(f.data + 6, static_cast<std::uint16_t>(scale_saturating<std::int16_t>(
                          feedback.velocity_rad_s, kVelocityActualUnit_rad_s)));
  return f;
}

namespace {
Result<can_frame> encode_triple(canid_t base, std::uint8_t node, const std::array<double, 3>& v,
                                double unit) {
  if (!is_sensor_node(node)) return CodecError::wrong_cob_id;
  for (double x : v) {
    if (std::isnan(x)) return CodecError::not_a_number;
  }
  can_frame f = make_frame(base + node, 6);
  for (int i = 0; i < 3; ++i) {
    put_u16(f.data + 2 * i,
            static_cast<std::uint16_t>(scale_saturating<std::int16_t>(v[static_cast<std::size_t>(i)], unit)));
  }
  return f;
}

std::array<double, 3> decode_triple(const can_frame& f, double unit) {
  std::array<double, 3> v{};
  for (int i = 0; i < 3; ++i) {
    v[static_cast<std::size_t>(i)] =
        static_cast<std::int16_t>(get_u16(f.data + 2 * i)) * unit;
  }
  return v;
}
}  // namespace

Result<can_frame> encode_sensor_force(const SensorForce& force) {
  return encode_triple(cob::kTpdo1Base, force.node, force.force_N, kForceUnit_N);
}

Result<can_frame> encode_sensor_torque(const SensorTorque& torque) {
  return encode_triple(cob::kTpdo2Base, torque.node, torque.torque_Nm, kTorqueUnit_Nm);
}

Result<can_frame> encode_sdo_request(const SdoRequest& request) {
  if (!valid_node(request.node)) return CodecError::wrong_cob_id;
  can_frame f = make_frame(cob::kSdoRequestBase + request.node, 8);
  if (request.kind == SdoRequestKind::upload) {
    f.data[0] = sdo::kUploadRequest;
  } else {
    switch (request.data_size) {
      case 1: f.data[0] = sdo::kDownload1; break;
      case 2: f.data[0] = sdo::kDownload2; break;
      case 4: f.data[0] = sdo::kDownload4; break;
      default: return CodecError::out_of_range;
    }
    if (!fits(request.data, request.data_size)) return CodecError::out_of_range;
    put_u32(f.data + 4, request.data);
  }
  put_u16(f.data + 1, request.index);
  f.data[3] = request.subindex;
  return f;
}

Result<can_frame> encode_sdo_response(const SdoResponse& response) {
  if (!valid_node(response.node)) return CodecError::wrong_cob_id;
  can_frame f = make_frame(cob::kSdoResponseBase + response.node, 8);
  switch (response.kind) {
    case SdoResponseKind::download_ack: f.data[0] = sdo::kDownloadResponse; break;
    case SdoResponseKind::abort:
      f.data[0] = sdo::kAbort;
      put_u32(f.data + 4, response.data);
      break;
    case SdoResponseKind::upload_data:
      switch (response.data_size) {
        case 1: f.data[0] = sdo::kUpload1; break;
        case 2: f.data[0] = sdo::kUpload2; break;
        case 4: f.data[0] = sdo::kUpload4; break;
        default: return CodecError::out_of_range;
      }
      if (!fits(response.data, response.data_size)) return CodecError::out_of_range;
      put_u32(f.data + 4, response.data);
      break;
  }
  put_u16(f.data + 1, response.index);
  f.data[3] = response.subindex;
  return f;
}

// ---- decoders ----------------------------------------------------------------------------

Result<NmtFrame> decode_nmt(const can_frame& f) {
  std::uint8_t unused = 0;
  if (auto e = check(f, cob::kNmt, 0, 0, 2, unused)) return *e;
  if (!valid_nmt_command(f.data[0])) return CodecError::unknown_command;
  if (f.data[1] > 127) return CodecError::out_of_range;
  return NmtFrame{static_cast<NmtCommand>(f.data[0]), f.data[1]};
}

Result<SyncFrame> decode_sync(const can_frame& f) {
  std::uint8_t unused = 0;
  if (auto e = check(f, cob::kSync, 0, 0, 1, unused)) return *e;
  if (f.data[0] < 1 || f.data[0] > kSyncCounterMax) return CodecError::out_of_range;
  return SyncFrame{f.data[0]};
}

Result<HeartbeatFrame> decode_heartbeat(const can_frame& f) {
  std::uint8_t node = 0;
  if (auto e = check(f, cob::kHeartbeatBase, 1, 127, 1, node)) return *e;
  if (!valid_nmt_state(f.data[0])) return CodecError::out_of_range;
  return HeartbeatFrame{node, static_cast<NmtState>(f.data[0])};
}

Result<EmcyFrame> decode_emcy(const can_frame& f) {
  std::uint8_t node = 0;
  if (auto e = check(f, cob::kEmcyBase, 1, 127, 8, node)) return *e;
  return EmcyFrame{node, get_u16(f.data), f.data[2]};
}

Result<DriveCommand> decode_drive_command(const can_frame& f) {
  std::uint8_t node = 0;
  if (auto e = check(f, cob::kRpdo1Base, 1, kDriveCount, 6, node)) return *e;
  const auto velocity = static_cast<std::int32_t>(get_u32(f.data + 2));
  return DriveCommand{node, get_u16(f.data), velocity * kTargetVelocityUnit_rad_s};
}

Result<DriveFeedback> decode_drive_feedback(const can_frame& f) {
  std::uint8_t node = 0;
  if (auto e = check(f, cob::kTpdo1Base, 1, kDriveCount, 8, node)) return *e;
  const auto position = static_cast<std::int32_t>(get_u32(f.data + 2));
  const auto velocity = static_cast<std::int16_t>(get_u16(f.data + 6));
  return DriveFeedback{node, get_u16(f.data), position * kPositionUnit_rad,
                       velocity * kVelocityActualUnit_rad_s};
}

Result<SensorForce> decode_sensor_force(const can_frame& f) {
  std::uint8_t node = 0;
  if (auto e = check(f, cob::kTpdo1Base, kWristSensorNode, kJoystickSensorNode, 6, node)) return *e;
  return SensorForce{node, decode_triple(f, kForceUnit_N)};
}

Result<SensorTorque> decode_sensor_torque(const can_frame& f) {
  std::uint8_t node = 0;
  if (auto e = check(f, cob::kTpdo2Base, kWristSensorNode, kJoystickSensorNode, 6, node)) return *e;
  return SensorTorque{node, decode_triple(f, kTorqueUnit_Nm)};
}

Result<SdoRequest> decode_sdo_request(const can_frame& f) {
  std::uint8_t node = 0;
  if (auto e = check(f, cob::kSdoRequestBase, 1, 127, 8, node)) return *e;
  SdoRequest r{node, SdoRequestKind::upload, get_u16(f.data + 1), f.data[3], 0, 0};
  if (f.data[0] == sdo::kUploadRequest) return r;
  const auto size = sdo_size_of(f.data[0], sdo::kDownload1, sdo::kDownload2, sdo::kDownload4);
  if (!size) return CodecError::unknown_command;
  r.kind = SdoRequestKind::download;
  r.data_size = *size;
  r.data = get_u32(f.data + 4);
  // Expedited with size indicated: bytes beyond the size are unused and must not carry data.
  if (!fits(r.data, r.data_size)) return CodecError::out_of_range;
  return r;
}

Result<SdoResponse> decode_sdo_response(const can_frame& f) {
  std::uint8_t node = 0;
  if (auto e = check(f, cob::kSdoResponseBase, 1, 127, 8, node)) return *e;
  SdoResponse r{node, SdoResponseKind::download_ack, get_u16(f.data + 1), f.data[3], 0, 0};
  if (f.data[0] == sdo::kDownloadResponse) return r;
  if (f.data[0] == sdo::kAbort) {
    r.kind = SdoResponseKind::abort;
    r.data = get_u32(f.data + 4);
    return r;
  }
  const auto size = sdo_size_of(f.data[0], sdo::kUpload1, sdo::kUpload2, sdo::kUpload4);
  if (!size) return CodecError::unknown_command;
  r.kind = SdoResponseKind::upload_data;
  r.data_size = *size;
  r.data = get_u32(f.data + 4);
  if (!fits(r.data, r.data_size)) return CodecError::out_of_range;
  return r;
}

// ---- classification ----------------------------------------------------------------------

Classified classify(const can_frame& f) {
  if (!is_classic(f)) return {FrameType::unknown, 0};
  const canid_t id = f.can_id & CAN_SFF_MASK;
  const canid_t function = id & 0x780;
  const auto node = static_cast<std::uint8_t>(id & 0x7F);
  switch (function) {
    case 0x000: return node == 0 ? Classified{FrameType::nmt, 0} : Classified{FrameType::unknown, 0};
    case 0x080: return node == 0 ? Classified{FrameType::sync, 0} : Classified{FrameType::emcy, node};
    case cob::kTpdo1Base:
      if (is_drive_node(node)) return {FrameType::drive_feedback, node};
      if (is_sensor_node(node)) return {FrameType::sensor_force, node};
      break;
    case cob::kRpdo1Base:
      if (is_drive_node(node)) return {FrameType::drive_command, node};
      break;
    case cob::kTpdo2Base:
      if (is_sensor_node(node)) return {FrameType::sensor_torque, node};
      break;
    case cob::kSdoResponseBase:
      if (node != 0) return {FrameType::sdo_response, node};
      break;
    case cob::kSdoRequestBase:
      if (node != 0) return {FrameType::sdo_request, node};
      break;
    case cob::kHeartbeatBase:
      if (node != 0) return {FrameType::heartbeat, node};
      break;
    default: break;
  }
  return {FrameType::unknown, 0};
}

}  // namespace rtm::can
