// SPDX-License-Identifier: Apache-2.0
// BusCycle: the PA10 master's SYNC cycle as an object with no thread, like the simulator's
// devices. Whoever owns time runs it: the master's own activity (Pa10Master::run_periodic),
// the servo's shared tick (fast mode), a test or the simulator stepping in lock-step.
//
//   receive(now)   everything that arrived is read; the window of the previous SYNC closes:
//                  joint feedback and wrenches are assembled and published, the supervisor
//                  checks the drives and the heartbeats
//   transmit(now)  the requests are taken (target, quick stop, fault reset), the 7 RPDOs and
//                  SYNC leave in one write, the window of this SYNC opens
//   step()         lock-step: transmit, then wait until every drive and sensor answered (or
//                  step_timeout_ns), then close the window
//
// Other threads talk to the cycle only through its Mailbox: requests in, a report out, each
// one struct under one mutex held for a copy, never across a send or a wait. The cycle does no
// allocation, no logging and no I/O other than its CAN frames.
#pragma once

#include <poll.h>

#include <array>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>

#include "arm/can/answer_ledger.h"
#include "arm/can/bus.h"
#include "arm/can/following_error.h"
#include "arm/can/master_types.h"
#include "arm/can/supervisor.h"
#include "arm/can/joint_assembly.h"
#include "arm/can/wrench_assembly.h"
#include "rt/clock.h"

namespace rtm::can {

inline constexpr std::size_t kSensorCount = 2;
// Slot 0: the wrist sensor, 1: the joystick.
constexpr std::size_t sensor_slot(ForceSensor s) { return s == ForceSensor::wrist ? 0 : 1; }
constexpr std::size_t sensor_slot(std::uint8_t node) { return node == kWristSensorNode ? 0 : 1; }

// What other threads ask of the cycle.
struct CycleRequests {
  std::array<double, kDriveCount> target_rad_s{};
  bool target_valid = false;        // false: zero is sent
  std::uint64_t target_sequence = 0;  // of the last accepted target (0: none yet)
  bool fault_reset = false;
  bool quick_stop = false;
};

// What the cycle tells them, as of its last receive (or step).
struct CycleReport {
  JointState state{};
  std::array<Wrench, kSensorCount> wrench{};
  FaultRecord fault{};
  MasterCounters counters{};
  bool enabled = false;        // every drive enabled, no fault, not enabling
  bool quick_stopped = false;  // every drive braked by a quick stop still requested
  SentTarget last_sent{};
};

// The one place the cycle and other threads share.
class Mailbox {
 public:
  template <class F>
  auto with_requests(F f) {
    std::lock_guard lock(mutex_);
    return f(requests_, report_);
  }
  template <class F>
  auto with_report(F f) const {
    std::lock_guard lock(mutex_);
    return f(report_);
  }

 private:
  friend class BusCycle;
  mutable std::mutex mutex_;
  CycleRequests requests_{};
  CycleReport report_{};
};

class BusCycle {
 public:
  // `sensor_bus` may be null: the sensors are then read from `drive_bus`. Owns both.
  BusCycle(std::unique_ptr<Bus> drive_bus, std::unique_ptr<Bus> sensor_bus, MasterConfig config);

  // ---- the cycle (one thread at a time; CLOCK_MONOTONIC ns) ----
  void receive(std::int64_t now_ns);
  void transmit(std::int64_t now_ns);
  bool step();  // true when every expected answer came within step_timeout_ns
  // A transport error: latched as a bus fault, published.
  void bus_failure(const std::exception& error);
  // Zero velocity and "shutdown" to every drive with one last SYNC, then NMT pre-operational.
  void shutdown();

  Mailbox& mailbox() { return mailbox_; }
  const Mailbox& mailbox() const { return mailbox_; }
  const MasterConfig& config() const { return config_; }
  void set_period_ns(std::int64_t period_ns) { config_.period_ns = period_ns; }
  Supervisor& supervisor() { return supervisor_; }
  std::string describe_buses() const;
  const Bus& drive_bus() const { return *drive_bus_; }
  const Bus& sensor_bus() const { return *sensor_bus_; }

  // ---- for the start-up sequence (startup.h) ----
  void send_nmt_all(NmtCommand command);
  // One SDO request and its answer; throws (fail()) on timeout or abort.
  SdoResponse sdo_transfer(const SdoRequest& request, const char* what);
  // Handles frames until done() or deadline_ns; true when done.
  template <class Done>
  bool receive_until(std::int64_t deadline_ns, Done done) {
    for (;;) {
      drain();
      if (done()) return true;
      if (!wait_readable(deadline_ns)) return done();
    }
  }
  bool answered(std::size_t joint) const { return joints_.answered(joint); }
  std::uint16_t statusword(std::size_t joint) const { return last_statusword_[joint]; }
  // Publishes everything as of now (start-up: once every drive is enabled).
  void publish_now(bool enabled) { publish(DriveSummary{enabled, false}); }
  [[noreturn]] void fail(const std::string& what) const;

 private:
  void handle(const can_frame& frame, std::int64_t now_ns);
  void handle_sensor(const can_frame& frame, const Classified& c);
  // A master-side frame we did not send (we never read our own): a fault once started.
  void foreign(const can_frame& frame, const Classified& c);
  // A TPDO from `node`, matched in its ledger: false when nobody asked for it (a fault once
  // started, and the window's values from that node are not published).
  bool solicited(AnswerLedger& ledger, std::uint8_t node, const char* what);
  void check_following();
  void drain();
  bool wait_readable(std::int64_t deadline_ns);  // false once deadline_ns has passed
  bool window_complete() const;
  void take_requests(std::int64_t now_ns);
  void expire_stale_target(CycleRequests& r);
  void send(Bus& bus, const Result<can_frame>& frame);
  void add(const Result<can_frame>& frame);
  void send_cycle(std::int64_t now_ns);
  // count_silence: whether a drive that did not answer counts towards missed_feedback_limit.
  void close_window(std::int64_t now_ns, bool count_silence);
  void publish(const DriveSummary& drives);
  void publish_sent(std::uint64_t sequence);
  // The sensor in slot k is configured (MasterConfig::sensors): the supervisor watches it.
  bool sensor_enabled(std::size_t k) const {
    return supervisor_.node_expected(sensor_node(k == 0 ? ForceSensor::wrist : ForceSensor::joystick));
  }

  std::unique_ptr<Bus> drive_bus_;
  std::unique_ptr<Bus> separate_sensor_bus_;  // null: sensors share drive_bus_
  Bus* sensor_bus_ = nullptr;
  MasterConfig config_;
  Supervisor supervisor_;
  Mailbox mailbox_;

  std::uint8_t sync_counter_ = 0;  // of the last SYNC sent
  std::uint64_t cycle_ = 0;
  std::int64_t sync_time_ns_ = 0;
  bool window_open_ = false;
  JointAssembly joints_;  // the drives' answers to the last SYNC
  std::array<std::uint16_t, kDriveCount> last_statusword_{};
  std::array<WrenchAssembly, kSensorCount> wrenches_{};
  std::uint8_t sdo_waiting_node_ = 0;
  std::optional<SdoResponse> sdo_response_;
  MasterCounters counters_{};
  std::array<double, kDriveCount> command_rad_s_{};
  std::uint64_t command_sequence_ = 0;  // of the target in command_rad_s_; 0 = zero, not a target
  std::uint64_t last_target_sequence_ = 0;  // the newest target seen by take_requests()
  int target_age_cycles_ = 0;               // cycles since it was new
  std::array<double, kDriveCount> sent_rad_s_{};    // the command sent with the last SYNC
  std::array<double, kDriveCount> acting_rad_s_{};  // the one sent with the SYNC before: what the
                                                    // answers to the last SYNC followed
  std::array<AnswerLedger, kDriveCount> drive_ledgers_;
  std::array<AnswerLedger, kSensorCount> force_ledgers_;
  std::array<AnswerLedger, kSensorCount> torque_ledgers_;
  FollowingErrorCheck following_;
  // A cycle's frames, one send_batch(): 7 RPDOs, SYNC, and while a fault takes the drives
  // down, 7 NMT pre-operational after the SYNC.
  std::array<can_frame, 2 * kDriveCount + 1> outgoing_{};
  std::size_t outgoing_count_ = 0;
};

}  // namespace rtm::can
