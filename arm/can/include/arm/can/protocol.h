// SPDX-License-Identifier: Apache-2.0
// The PA10 CAN protocol (CANopen subset, CiA 301 + CiA 402 cyclic synchronous velocity):
// constants and pure encode/decode functions for every frame. See docs/can-protocol.md.
//
// Used by both ends: the master (arm library) and the device side (pa10-sim, test fakes).
// Encoders take SI units and write scaled little-endian integers, saturating at the integer
// range; a NaN is rejected (CodecError::not_a_number), never sent. Decoders check the frame
// format, COB-ID, DLC and value ranges and return an error value, never read past can_dlc.
#pragma once

#include <linux/can.h>

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>

namespace rtm::can {

// ---- nodes -------------------------------------------------------------------------------

inline constexpr int kDriveCount = 7;                   // S1 S2 S3 E1 E2 W1 W2
inline constexpr std::uint8_t kFirstDriveNode = 1;      // drive of joint i (0-based) = 1 + i
inline constexpr std::uint8_t kWristSensorNode = 0x10;  // 6-axis F/T sensor at the flange
inline constexpr std::uint8_t kJoystickSensorNode = 0x11;  // the operator's force "joystick"

enum class ForceSensor : std::uint8_t { wrist, joystick };

constexpr std::uint8_t drive_node(int joint_index) {
  return static_cast<std::uint8_t>(kFirstDriveNode + joint_index);
}
constexpr bool is_drive_node(unsigned node) { return node >= 1 && node <= kDriveCount; }
constexpr int joint_index_of(std::uint8_t drive) { return drive - kFirstDriveNode; }
constexpr std::uint8_t sensor_node(ForceSensor s) {
  return s == ForceSensor::wrist ? kWristSensorNode : kJoystickSensorNode;
}
constexpr bool is_sensor_node(unsigned node) {
  return node == kWristSensorNode || node == kJoystickSensorNode;
}

// "S1".."W2" for joint index 0..6, "?" otherwise.
std::string_view joint_name(int joint_index);
// For messages: "drive 3 (S3)", "wrist sensor 0x10", "joystick sensor 0x11", "node 0x2a".
std::string node_description(unsigned node);

// ---- COB-IDs -----------------------------------------------------------------------------

namespace cob {
inline constexpr canid_t kNmt = 0x000;
inline constexpr canid_t kSync = 0x080;
inline constexpr canid_t kEmcyBase = 0x080;       // + node (1..127)
inline constexpr canid_t kTpdo1Base = 0x180;      // + node: drive feedback / sensor force
inline constexpr canid_t kRpdo1Base = 0x200;      // + drive: drive command
inline constexpr canid_t kTpdo2Base = 0x280;      // + sensor: sensor torque
inline constexpr canid_t kSdoResponseBase = 0x580;  // + node (server -> master)
inline constexpr canid_t kSdoRequestBase = 0x600;   // + node (master -> server)
inline constexpr canid_t kHeartbeatBase = 0x700;    // + node
}  // namespace cob

// ---- NMT, heartbeat, EMCY codes ----------------------------------------------------------

enum class NmtCommand : std::uint8_t {
  start = 0x01,
  stop = 0x02,
  enter_pre_operational = 0x80,
  reset_node = 0x81,
  reset_communication = 0x82,
};
inline constexpr std::uint8_t kNmtAllNodes = 0;

enum class NmtState : std::uint8_t {
  boot_up = 0x00,
  stopped = 0x04,
  operational = 0x05,
  pre_operational = 0x7F,
};
std::string_view to_string(NmtState state);

namespace emcy {
inline constexpr std::uint16_t kErrorReset = 0x0000;    // the node's error is cleared
inline constexpr std::uint16_t kRpdoTimeout = 0x8250;   // drive: no RPDO for 3 SYNC periods
inline constexpr std::uint16_t kHeartbeat = 0x8130;     // heartbeat / life guard error
inline constexpr std::uint16_t kSensorFault = 0x7300;
inline constexpr std::uint16_t kDeviceHardware = 0x5000;
}  // namespace emcy
// "RPDO timeout (command loss)" etc.; "unknown" for other codes.
std::string_view emcy_description(std::uint16_t error_code);

// ---- CiA 402 words and objects -----------------------------------------------------------

namespace controlword {
inline constexpr std::uint16_t kDisableVoltage = 0x0000;
inline constexpr std::uint16_t kQuickStop = 0x0002;
inline constexpr std::uint16_t kShutdown = 0x0006;
inline constexpr std::uint16_t kSwitchOn = 0x0007;
inline constexpr std::uint16_t kEnableOperation = 0x000F;
inline constexpr std::uint16_t kFaultResetBit = 0x0080;  // acts on its rising edge
}  // namespace controlword

namespace statusword {
inline constexpr std::uint16_t kStateMask = 0x006F;
inline constexpr std::uint16_t kNotReadyToSwitchOn = 0x0000;
inline constexpr std::uint16_t kSwitchOnDisabled = 0x0040;
inline constexpr std::uint16_t kReadyToSwitchOn = 0x0021;
inline constexpr std::uint16_t kSwitchedOn = 0x0023;
inline constexpr std::uint16_t kOperationEnabled = 0x0027;
inline constexpr std::uint16_t kQuickStopActive = 0x0007;
inline constexpr std::uint16_t kFaultReactionActive = 0x000F;
inline constexpr std::uint16_t kFault = 0x0008;
}  // namespace statusword

namespace object {
inline constexpr std::uint16_t kControlword = 0x6040;
inline constexpr std::uint16_t kStatusword = 0x6041;
inline constexpr std::uint16_t kModesOfOperation = 0x6060;         // i8, write 9
inline constexpr std::uint16_t kModesOfOperationDisplay = 0x6061;  // i8, read back
inline constexpr std::uint16_t kPositionActual = 0x6064;
inline constexpr std::uint16_t kVelocityActual = 0x606C;
inline constexpr std::uint16_t kTargetVelocity = 0x60FF;
inline constexpr std::int8_t kCyclicSynchronousVelocityMode = 9;
}  // namespace object

// ---- SDO ---------------------------------------------------------------------------------

namespace sdo {
inline constexpr std::uint8_t kDownload1 = 0x2F;  // expedited write, 1 data byte
inline constexpr std::uint8_t kDownload2 = 0x2B;
inline constexpr std::uint8_t kDownload4 = 0x23;
inline constexpr std::uint8_t kDownloadResponse = 0x60;
inline constexpr std::uint8_t kUploadRequest = 0x40;
inline constexpr std::uint8_t kUpload1 = 0x4F;  // expedited read response, 1 data byte
inline constexpr std::uint8_t kUpload2 = 0x4B;
inline constexpr std::uint8_t kUpload4 = 0x43;
inline constexpr std::uint8_t kAbort = 0x80;
// Abort codes (CiA 301) the devices here use.
inline constexpr std::uint32_t kAbortUnsupportedCommand = 0x05040001;
inline constexpr std::uint32_t kAbortReadOnly = 0x06010002;
inline constexpr std::uint32_t kAbortWriteOnly = 0x06010001;
inline constexpr std::uint32_t kAbortNoObject = 0x06020000;
inline constexpr std::uint32_t kAbortLengthMismatch = 0x06070010;
inline constexpr std::uint32_t kAbortValueRange = 0x06090030;
inline constexpr std::uint32_t kAbortWrongState = 0x08000022;  // not allowed in this NMT state
}  // namespace sdo

// ---- scaling -----------------------------------------------------------------------------

inline constexpr double kPositionUnit_rad = 1e-6;          // position_actual: 1 µrad
inline constexpr double kVelocityActualUnit_rad_s = 1e-3;  // velocity_actual: 1 mrad/s
inline constexpr double kTargetVelocityUnit_rad_s = 1e-6;  // target_velocity: 1 µrad/s
inline constexpr double kForceUnit_N = 0.01;
inline constexpr double kTorqueUnit_Nm = 0.001;
inline constexpr std::uint8_t kSyncCounterMax = 240;  // counter runs 1..240, then 1 again

constexpr std::uint8_t next_sync_counter(std::uint8_t counter) {
  return counter >= kSyncCounterMax ? 1 : static_cast<std::uint8_t>(counter + 1);
}

// ---- results -----------------------------------------------------------------------------

enum class CodecError : std::uint8_t {
  not_classic_frame,  // extended id, RTR or error frame
  wrong_cob_id,       // not the frame this decoder reads (or a node id out of range)
  wrong_dlc,
  out_of_range,       // a field outside its allowed values (SYNC counter 0, unknown NMT state…)
  unknown_command,    // NMT or SDO command byte not in the protocol
  not_a_number,       // encoder given NaN
};
std::string_view to_string(CodecError error);

// A value or the reason there is none. Small, trivially copyable when T is; no allocation.
template <class T>
class Result {
 public:
  Result(T value) : value_(std::move(value)), error_(), ok_(true) {}  // NOLINT: implicit by design
  Result(CodecError error) : value_(), error_(error), ok_(false) {}   // NOLINT
  bool ok() const { return ok_; }
  explicit operator bool() const { return ok_; }
  CodecError error() const { return error_; }  // meaningful only when !ok()
  // The value; precondition ok() (checked: calling it on an error is a logic_error).
  const T& value() const;
  const T& operator*() const { return value(); }
  const T* operator->() const { return &value(); }

 private:
  T value_;
  CodecError error_;
  bool ok_;
};

[[noreturn]] void throw_bad_result_access(CodecError error);
template <class T>
const T& Result<T>::value() const {
  if (!ok_) throw_bad_result_access(error_);
  return value_;
}

// ---- frame payloads ----------------------------------------------------------------------

struct NmtFrame {
  NmtCommand command;
  std::uint8_t node;  // 0 = all nodes
};
struct SyncFrame {
  std::uint8_t counter;  // 1..240
};
struct HeartbeatFrame {
  std::uint8_t node;
  NmtState state;
};
struct EmcyFrame {
  std::uint8_t node;
  std::uint16_t error_code;
  std::uint8_t error_register;
};
struct DriveCommand {  // RPDO1, master -> drive, latched on the next SYNC
  std::uint8_t drive;  // 1..7
  std::uint16_t controlword;
  double target_velocity_rad_s;
};
struct DriveFeedback {  // TPDO1, drive -> master, after each SYNC
  std::uint8_t drive;
  std::uint16_t statusword;
  double position_rad;
  double velocity_rad_s;
};
struct SensorForce {  // sensor TPDO1, sensor frame
  std::uint8_t node;  // 0x10 or 0x11
  std::array<double, 3> force_N;
};
struct SensorTorque {  // sensor TPDO2, sensor frame
  std::uint8_t node;
  std::array<double, 3> torque_Nm;
};

enum class SdoRequestKind : std::uint8_t { download, upload };
struct SdoRequest {  // master -> node (0x600 + node)
  std::uint8_t node;
  SdoRequestKind kind;
  std::uint16_t index;
  std::uint8_t subindex;
  std::uint32_t data;       // download: value, little-endian, zero-extended; upload: 0
  std::uint8_t data_size;   // download: 1, 2 or 4; upload: 0
};
enum class SdoResponseKind : std::uint8_t { download_ack, upload_data, abort };
struct SdoResponse {  // node -> master (0x580 + node)
  std::uint8_t node;
  SdoResponseKind kind;
  std::uint16_t index;
  std::uint8_t subindex;
  std::uint32_t data;        // upload_data: value; abort: abort code; download_ack: 0
  std::uint8_t data_size;    // upload_data: 1, 2 or 4; else 0
};

// ---- encoders ----------------------------------------------------------------------------
// Node ids outside the protocol's range are a programming error on the sending side and give
// CodecError::wrong_cob_id.

Result<can_frame> encode_nmt(NmtCommand command, std::uint8_t node);
Result<can_frame> encode_sync(std::uint8_t counter);
Result<can_frame> encode_heartbeat(std::uint8_t node, NmtState state);
Result<can_frame> encode_emcy(std::uint8_t node, std::uint16_t error_code,
                              std::uint8_t error_register);
Result<can_frame> encode_drive_command(const DriveCommand& command);
Result<can_frame> encode_drive_feedback(const DriveFeedback& feedback);
Result<can_frame> encode_sensor_force(const SensorForce& force);
Result<can_frame> encode_sensor_torque(const SensorTorque& torque);
Result<can_frame> encode_sdo_request(const SdoRequest& request);
Result<can_frame> encode_sdo_response(const SdoResponse& response);

// ---- decoders ----------------------------------------------------------------------------

Result<NmtFrame> decode_nmt(const can_frame& frame);
Result<SyncFrame> decode_sync(const can_frame& frame);
Result<HeartbeatFrame> decode_heartbeat(const can_frame& frame);
Result<EmcyFrame> decode_emcy(const can_frame& frame);
Result<DriveCommand> decode_drive_command(const can_frame& frame);
Result<DriveFeedback> decode_drive_feedback(const can_frame& frame);
Result<SensorForce> decode_sensor_force(const can_frame& frame);
Result<SensorTorque> decode_sensor_torque(const can_frame& frame);
Result<SdoRequest> decode_sdo_request(const can_frame& frame);
Result<SdoResponse> decode_sdo_response(const can_frame& frame);

// ---- classification ----------------------------------------------------------------------

// Which frame of the protocol a COB-ID is, from the id alone (the decoder then checks the
// rest). Lets a receive loop dispatch with one switch.
enum class FrameType : std::uint8_t {
  nmt,
  sync,
  emcy,
  drive_feedback,  // 0x180 + drive
  sensor_force,    // 0x180 + sensor
  drive_command,   // 0x200 + drive
  sensor_torque,   // 0x280 + sensor
  sdo_response,    // 0x580 + node
  sdo_request,     // 0x600 + node
  heartbeat,       // 0x700 + node
  unknown,         // not a PA10 protocol id (or extended/RTR/error frame)
};
struct Classified {
  FrameType type;
  std::uint8_t node;  // the node in the id (0 for NMT, SYNC, unknown)
};
Classified classify(const can_frame& frame);
std::string_view to_string(FrameType type);

}  // namespace rtm::can
