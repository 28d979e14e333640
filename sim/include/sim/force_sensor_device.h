// SPDX-License-Identifier: Apache-2.0
// The CAN side of one emulated 6-axis force/torque sensor (wrist 0x10, joystick 0x11).
//
// Pure logic like DriveDevice: fed frames and time, answers through a FrameSink, given the
// measured wrench when it must report. Implements NMT (boot-up, start/stop/pre-op/reset),
// the heartbeat, expedited SDO reads of 0x1017 (heartbeat ms) and aborts for anything else,
// and after each SYNC while operational TPDO1 (Fx, Fy, Fz, i16, 0.01 N) and TPDO2 (Tx, Ty, Tz,
// i16, 0.001 N·m), in the sensor frame, with the tare offset removed.
//
// Taring: the first `tare_samples` wrenches given to add_tare_sample() are averaged into the
// offset (pa10-sim feeds them while it holds the arm still before the nodes boot). Values
// beyond the i16 range saturate and raise EMCY 0x7300 (sensor fault) once; EMCY 0x0000 is sent
// when the reading is back in range.
//
// Fault injection: set_connected(false) cuts the node off the bus (it hears and sends
// nothing, heartbeat included, but keeps its state), as a pulled cable does.
#pragma once

#include <linux/can.h>

#include <cstdint>

#include "sim/frame_sink.h"
#include "sim/nmt_node.h"
#include "sim/wrench.h"

namespace rtm::sim {

struct ForceSensorConfig {
  std::uint8_t node_id = 0x10;                      // 0x10 wrist, 0x11 joystick
  std::int64_t heartbeat_period_ns = 100'000'000;   // 100 ms
  int tare_samples = 20;                            // samples averaged into the offset
};

// The PA10 sensor PDO scaling (N and N·m per count).
inline constexpr double kForcePerCount_N = 0.01;
inline constexpr double kTorquePerCount_Nm = 0.001;

class ForceSensorDevice {
 public:
  explicit ForceSensorDevice(ForceSensorConfig config);

  // Sends the boot-up heartbeat and enters pre-operational.
  void power_on(std::int64_t now_ns, FrameSink& out);
  // One frame seen on the bus (NMT, SYNC, SDO for this node; anything else ignored).
  void on_frame(const can_frame& frame, std::int64_t now_ns, FrameSink& out);
  // Sends TPDO1+TPDO2 of (raw - offset) if a SYNC was seen since the last report and the
  // node is operational; does nothing otherwise. `raw` is the wrench the tool side receives
  // from outside, in the sensor frame.
  void send_tpdo(const Wrench& raw, FrameSink& out);
  void tick(std::int64_t now_ns, FrameSink& out);
  void send_heartbeat(FrameSink& out) { nmt_.send_heartbeat(wire(out)); }

  void set_connected(bool connected) { connected_ = connected; }
  bool connected() const { return connected_; }

  // Taring: averages the first config.tare_samples samples; later samples are ignored.
  void add_tare_sample(const Wrench& raw);
  bool tared() const { return tare_count_ >= config_.tare_samples; }
  const Wrench& offset() const { return offset_; }

  // (raw - offset) as it will travel on the bus: the counts, saturated to i16.
  struct Counts {
    std::int16_t force[3];
    std::int16_t torque[3];
    bool saturated;
  };
  Counts to_counts(const Wrench& raw) const;

  std::uint8_t node_id() const { return config_.node_id; }
  std::uint8_t nmt_state() const { return nmt_.state(); }
  std::uint8_t last_sync_counter() const { return last_sync_counter_; }  // 0: none seen

 private:
  void handle_sdo(const can_frame& frame, FrameSink& out);
  void send_emcy(std::uint16_t code, FrameSink& out);
  FrameSink& wire(FrameSink& out) { return connected_ ? out : null_sink_; }

  ForceSensorConfig config_;
  NmtNode nmt_;
  bool tpdo_due_ = false;
  bool overload_reported_ = false;
  int tare_count_ = 0;
  Wrench tare_sum_{};
  Wrench offset_{};
  std::uint8_t last_sync_counter_ = 0;
  bool connected_ = true;
  NullSink null_sink_;
};

}  // namespace rtm::sim
