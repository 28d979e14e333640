// SPDX-License-Identifier: Apache-2.0
// The master's supervisor: what the bus cycle may command, and when the arm must stop.
//   faults      the first cause latches, with a reason in a fixed buffer (no allocation);
//               from then on every drive gets zero until a fault reset
//   quick stop  CiA 402 quick stop of every drive on request, held without a fault, and the
//               grace period after it while the drives return to operation enabled
//   enabling    the CiA 402 enable sequence at start-up and after a fault reset, with its
//               deadline
//   watchdogs   heartbeats (a node silent too long, a node no longer operational), EMCYs,
//               drives missing several SYNCs in a row, drives leaving operation enabled
// Thread-free and clock-free: the cycle passes every frame and CLOCK_MONOTONIC time in ns.
#pragma once

#include <array>
#include <cstdint>

#include "arm/can/cia402.h"
#include "arm/can/master_types.h"

namespace rtm::can {

// The fault as the cycle keeps it: a fixed buffer, so latching one does not allocate.
struct FaultRecord {
  FaultKind kind = FaultKind::none;
  std::uint8_t node = 0;
  std::uint16_t code = 0;
  std::array<char, 192> reason{};
  bool active() const { return kind != FaultKind::none; }
};

// What the drives' latest statuswords say, for the report.
struct DriveSummary {
  bool all_enabled = true;         // every drive operation enabled (or braked on request)
  bool all_quick_stopped = false;  // every drive quick stop active, on request
};

class Supervisor {
 public:
  // expected[node]: the nodes that must stay alive (the drives and the configured sensors).
  Supervisor(const MasterConfig& config, const std::array<bool, 128>& expected);

  // ---- the fault ----
  // Latches the first cause (later ones are ignored until fault_reset) and ends enabling.
  void latch(FaultKind kind, std::uint8_t node, std::uint16_t code, const char* format, ...)
      __attribute__((format(printf, 5, 6)));
  const FaultRecord& fault() const { return fault_; }
  bool faulted() const { return fault_.active(); }

  // ---- phases ----
  bool node_expected(std::uint8_t node) const { return expected_[node]; }
  bool started() const { return started_; }
  bool enabling() const { return enabling_; }
  bool recovering() const { return recovering_; }
  // NMT start was sent at now_ns: nodes must stay operational from a heartbeat timeout on,
  // the heartbeat watch restarts, and the drives are enabled.
  void on_nmt_start(std::int64_t now_ns);
  // Every drive reached operation enabled at start-up.
  void enabled_at_startup() { enabling_ = false; }
  // A recovery cycle sends NMT start again: the state check waits a heartbeat timeout.
  void on_nmt_restart(std::int64_t now_ns) { state_check_from_ns_ = now_ns + heartbeat_timeout_ns_; }

  // ---- requests, taken at the start of each transmit ----
  // fault_reset(): clears the fault and starts the enable sequence, due within enable_timeout_ns.
  void take_fault_reset(std::int64_t now_ns);
  // Whether a quick stop is requested this cycle (ignored while faulted or enabling).
  void take_quick_stop(bool requested, std::int64_t now_ns);
  bool quick_stop() const { return quick_stop_; }
  // A target may go out this cycle: no fault, not enabling, no quick stop.
  bool may_move() const { return !fault_.active() && !enabling_ && !quick_stop_; }

  // ---- what the cycle sends: the controlword for drive `joint` given its last statusword ----
  std::uint16_t controlword(std::size_t joint, std::uint16_t statusword);

  // ---- frames ----
  void on_heartbeat(std::uint8_t node, NmtState state, std::int64_t now_ns);
  void on_emcy(std::uint8_t node, std::uint16_t code);
  bool heard_from(std::uint8_t node) const { return last_heartbeat_ns_[node] != 0; }

  // ---- watchdogs, once per cycle ----
  void check_heartbeats(std::int64_t now_ns);
  // The answers to one SYNC closed at now_ns: got[j] whether drive j answered, statusword[j]
  // its latest statusword (kept from earlier SYNCs when it did not answer). count_silence:
  // whether a drive that did not answer counts towards missed_feedback_limit (not when the
  // window closed late: a stall of the master's process or host).
  DriveSummary check_drives(const std::array<bool, kDriveCount>& got,
                            const std::array<std::uint16_t, kDriveCount>& statusword, std::int64_t now_ns,
                            bool count_silence = true);

 private:
  bool quick_stop_expected(std::int64_t now_ns) const;
  void check_drive(int joint, std::uint16_t statusword);
  void check_recovery(const std::array<std::uint16_t, kDriveCount>& statusword, bool all_enabled,
                      std::int64_t now_ns);

  std::array<bool, 128> expected_;
  int missed_feedback_limit_;
  std::int64_t heartbeat_timeout_ns_;
  std::int64_t enable_timeout_ns_;
  FaultRecord fault_{};
  bool started_ = false;     // NMT start sent: nodes must stay operational from then on
  bool enabling_ = false;    // start-up or recovery: the CiA 402 enable sequence runs
  bool recovering_ = false;  // after a fault reset
  std::int64_t recovery_deadline_ns_ = 0;
  std::int64_t state_check_from_ns_ = 0;  // heartbeat states are checked from then on
  bool quick_stop_ = false;
  // After a quick stop ends, drives report quick stop active until they have latched "enable
  // operation": that is no fault until this deadline (0: none) or all are enabled again.
  std::int64_t quick_stop_release_deadline_ns_ = 0;
  std::array<Cia402Enabler, kDriveCount> enablers_{};
  std::array<int, kDriveCount> missed_{};
  std::array<std::int64_t, 128> last_heartbeat_ns_{};  // 0: never heard
};

}  // namespace rtm::can
