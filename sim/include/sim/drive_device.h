// SPDX-License-Identifier: Apache-2.0
// The CAN side of one emulated PA10 joint drive: a CiA 402 device speaking the PA10 protocol
// (docs/can-protocol.md), with the PA10 firmware's command-loss safety.
//
// The class is pure logic: it is fed frames and the bus time and answers through a FrameSink.
// It owns no physics: it tells the joint servo (Pa10Plant) what to do through command(), and
// is told the joint's measured state when it must report it (send_tpdo()). That keeps the
// protocol behaviour testable frame by frame, without MuJoCo and without a transport.
//
// What it implements:
//   - NMT: boot-up message at power_on(), then pre-operational; start/stop/pre-op/reset node/
//     reset communication, addressed to its node id or to all (node 0);
//   - heartbeat every heartbeat_period_ns of the time given to tick(), with the NMT state;
//   - expedited SDO: 0x6060:00 mode of operation (i8, writable in pre-operational only, only
//     9 = cyclic synchronous velocity accepted), 0x6061:00 mode display, 0x6041:00 statusword,
//     0x1017:00 heartbeat period (u16 ms); position/velocity actual travel in TPDO1 only (an
//     SDO read of them is aborted), anything else is answered with an SDO abort;
//   - the CiA 402 state machine driven by the controlword of RPDO1 (operational only);
//   - RPDO1 (controlword, target velocity) latched at the next SYNC; TPDO1 (statusword,
//     position, velocity) after each SYNC while operational;
//   - safety: in operation enabled, when `rpdo_timeout_syncs` SYNCs in a row arrive without an
//     RPDO1 in between, the drive brakes (command() becomes hold), sends EMCY 0x8250 and enters
//     fault; a fault reset (controlword bit 7 rising) clears it and sends EMCY 0x0000. The same
//     happens when the master falls silent altogether (no SYNC either) for
//     `rpdo_silence_timeout_ns` of device time, so a dead master does not leave the arm moving.
//
// Fault injection, what one does to a real drive on a test bench: inject_fault() (a hardware
// fault, or any EMCY code), set_fault_persistent() (a fault reset does not take),
// set_connected(false) (the cable pulled: the node hears and sends nothing but keeps running),
// lose_next_tpdos() / lose_next_rpdos() (PDOs lost on the bus); DriveConfig::offers_csv_mode = false is a drive
// whose firmware lacks cyclic synchronous velocity.
#pragma once

#include <linux/can.h>

#include <cstdint>

#include "arm/can/cia402.h"
#include "sim/frame_sink.h"
#include "sim/nmt_node.h"

namespace rtm::sim {

// The joint's measured state, as the drive reports it in TPDO1.
struct JointState {
  double position_rad = 0;
  double velocity_rad_s = 0;
};

// What the drive asks of its joint servo.
struct JointCommand {
  enum class Mode : std::uint8_t {
    hold,      // brake engaged: keep the position the joint had when the brake engaged
    velocity,  // follow target_velocity_rad_s (only in CiA 402 "operation enabled")
  };
  Mode mode = Mode::hold;
  double target_velocity_rad_s = 0;  // rad/s; 0 in hold
};

struct DriveConfig {
  std::uint8_t node_id = 1;                         // 1..7 for S1..W2
  std::int64_t heartbeat_period_ns = 100'000'000;   // 0x1017, 100 ms
  int rpdo_timeout_syncs = 3;                       // SYNCs without RPDO1 before the fault
  // Device time without any RPDO1 before the fault, for a master that stopped sending SYNC
  // too. Generous: a host stall of the master must not fault the drives in real time.
  std::int64_t rpdo_silence_timeout_ns = 100'000'000;
  // The firmware offers mode 9 (cyclic synchronous velocity); without it an SDO write of
  // 0x6060 = 9 is aborted (0x06090030, value range), as for any other mode.
  bool offers_csv_mode = true;
};

class DriveDevice {
 public:
  explicit DriveDevice(DriveConfig config);

  // Power on (or reset node): sends the boot-up heartbeat (0x700+id, [0x00]) and enters
  // pre-operational, CiA 402 "switch-on disabled", mode of operation 0 (none), brake engaged.
  void power_on(std::int64_t now_ns, FrameSink& out);

  // One frame seen on the bus; frames for other nodes or of other kinds are ignored. A SYNC
  // latches the last RPDO1 and runs the command-loss check; the caller then reports the
  // joint's state with send_tpdo() (after stepping the physics, in lock-step).
  void on_frame(const can_frame& frame, std::int64_t now_ns, FrameSink& out);

  // Sends TPDO1 with `state` if a SYNC was seen since the last TPDO1 and the node is
  // operational; does nothing otherwise.
  void send_tpdo(const JointState& state, FrameSink& out);

  // Advances the device clock: sends the heartbeat when its period has elapsed; faults an
  // enabled drive whose master has been silent for rpdo_silence_timeout_ns.
  void tick(std::int64_t now_ns, FrameSink& out);

  // Sends a heartbeat now (pa10-sim's lock-step mode also beats on the wall clock, so a
  // master that watches heartbeats in real time is served while no SYNC flows).
  void send_heartbeat(FrameSink& out) { nmt_.send_heartbeat(wire(out)); }

  // What the joint servo must do now.
  JointCommand command() const;

  // Fault injection. The drive faults now: brake engaged, statusword fault, EMCY `emcy_code`
  // (e.g. emcy::kDeviceHardware) to `out`. A fault reset clears it as any other fault.
  void inject_fault(std::uint16_t emcy_code, FrameSink& out);
  // While set, a fault reset leaves the drive in fault (broken hardware).
  void set_fault_persistent(bool persistent) { fault_persistent_ = persistent; }
  // Disconnected, the node neither hears the bus nor sends on it (boot-up, heartbeat, SDO,
  // TPDO, EMCY are lost) but keeps running: its command-loss guard faults it as on a real bus.
  void set_connected(bool connected) { connected_ = connected; }
  bool connected() const { return connected_; }
  // The next `count` TPDO1s it sends, or RPDO1s sent to it, are lost on the bus (RPDOs lost
  // for rpdo_timeout_syncs SYNCs in a row trip its command-loss guard).
  void lose_next_tpdos(int count) { tpdos_to_lose_ = count; }
  void lose_next_rpdos(int count) { rpdos_to_lose_ = count; }

  std::uint8_t node_id() const { return config_.node_id; }
  std::uint8_t nmt_state() const { return nmt_.state(); }          // 0x04/0x05/0x7F
  std::uint16_t statusword() const { return drive_.statusword(); }  // 0x6041
  rtm::can::DriveState drive_state() const { return drive_.state(); }
  std::int8_t mode_of_operation() const { return mode_; }          // 0x6060/0x6061
  bool in_fault() const { return drive_.state() == rtm::can::DriveState::fault; }
  double target_velocity_rad_s() const { return target_velocity_rad_s_; }  // latched at SYNC
  std::uint16_t controlword() const { return controlword_; }                // latched at SYNC
  std::uint32_t syncs_seen() const { return syncs_seen_; }
  std::uint8_t last_sync_counter() const { return last_sync_counter_; }  // 0: none, or no counter

 private:
  void handle_nmt(const can_frame& frame, std::int64_t now_ns, FrameSink& out);
  void handle_sync(std::uint8_t counter, std::int64_t now_ns, FrameSink& out);
  void handle_rpdo(const can_frame& frame, std::int64_t now_ns);
  void handle_sdo(const can_frame& frame, FrameSink& out);
  void enter_fault(std::uint16_t emcy_code, FrameSink& out);
  void send_emcy(std::uint16_t code, FrameSink& out);
  FrameSink& wire(FrameSink& out) { return connected_ ? out : null_sink_; }

  DriveConfig config_;
  NmtNode nmt_;
  rtm::can::Cia402Drive drive_;
  std::int8_t mode_ = 0;
  // RPDO1 as received, and as latched at the last SYNC.
  bool rpdo_pending_ = false;
  std::uint16_t pending_controlword_ = 0;
  double pending_velocity_rad_s_ = 0;
  double target_velocity_rad_s_ = 0;
  std::uint16_t controlword_ = 0;
  int syncs_without_rpdo_ = 0;
  std::int64_t last_rpdo_ns_ = 0;  // device time of the last RPDO1 (or of enabling)
  bool tpdo_due_ = false;
  std::uint32_t syncs_seen_ = 0;
  std::uint8_t last_sync_counter_ = 0;
  bool fault_persistent_ = false;
  bool connected_ = true;
  int tpdos_to_lose_ = 0;
  int rpdos_to_lose_ = 0;
  NullSink null_sink_;
};

}  // namespace rtm::sim
