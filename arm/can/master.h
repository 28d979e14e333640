// Pa10Master: the CANopen master of the PA10 - NMT master, SYNC producer, PDO exchange with
// the 7 drives and reception of the two force sensors.
//
// Use: construct (buses open), start() (startup sequence, blocking, throws on failure), then
// either run_periodic() (own thread, absolute 2 ms schedule) or step() per cycle (lock-step:
// e.g. driven by a simulator clock); a periodic caller may take run_periodic()'s cycles over
// and run them itself (take_over_cycles(), receive_cycle(), transmit_cycle()). From any
// thread: set_target_velocities(), joint_state(), wrench(), fault(), fault_reset(), counters().
//
// One cycle: read what arrived for the previous SYNC, publish it, check faults and
// heartbeats, write the 7 RPDOs (controlword + target velocity) and SYNC in one
// Bus::send_batch(). The cycle does no
// allocation, no logging, no I/O other than the CAN frames; the shared state is guarded by a
// mutex held only for copies, never across a send or a wait.
//
// Faults (drive statusword fault, an EMCY with a non-zero code, a node silent for longer than
// the heartbeat timeout, a bus error, a drive leaving operation enabled): latched with a reason;
// the master then commands zero velocity to every drive and forgets the last target until
// set_target_velocities() is called again after fault_reset().
//
// Quick stop (CiA 402): quick_stop() makes the next cycles send controlword 0x0002 with zero
// target to every drive, which then brakes and reports "quick stop active" (0x0007); the master
// holds them there (no fault: it asked for that state) until set_target_velocities() resumes,
// when "enable operation" (0x000F, transition 16) takes them straight back to operation enabled
// with the new target in the same RPDO.
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "arm/can/bus.h"
#include "arm/can/cia402.h"
#include "arm/can/protocol.h"

namespace rtm::can {

using SteadyTime = std::chrono::steady_clock::time_point;

struct MasterConfig {
  std::chrono::nanoseconds period{2'000'000};                 // SYNC period
  std::chrono::milliseconds boot_timeout{5000};               // all nodes seen (boot-up/heartbeat)
  std::chrono::milliseconds sdo_timeout{500};                 // per SDO request
  std::chrono::milliseconds enable_timeout{2000};             // all drives operation enabled
  std::chrono::milliseconds heartbeat_timeout{300};           // node silent longer -> fault
  std::chrono::nanoseconds step_timeout{std::chrono::milliseconds(100)};  // lock-step wait
  // A drive silent for more consecutive SYNCs -> fault. 25 cycles = 50 ms: longer than the
  // 5-40 ms host stalls a VM shows (a dead node is caught by the heartbeat after 300 ms anyway).
  int missed_feedback_limit = 25;
  // Force sensors the master listens to (and waits for at startup and in step()).
  std::vector<ForceSensor> sensors{ForceSensor::wrist, ForceSensor::joystick};
  // While another thread runs the cycles (take_over_cycles()): if it sends no SYNC for this
  // many periods in a row in which run_periodic()'s idle thread itself woke on time (so not a
  // stall of the whole process or host), that thread takes the cycles back and latches
  // FaultKind::cycle_owner_lost (zero velocity). Without it a hung owner would leave each drive
  // at its last latched velocity: the drives' RPDO timeout counts SYNCs, and none come.
  int taken_over_timeout_periods = 5;
  // run_periodic(): SCHED_FIFO priority (0 = keep SCHED_OTHER) and CPU to pin to (-1 = none).
  int realtime_priority = 0;
  int cpu = -1;
};

struct JointState {
  std::array<double, kDriveCount> position_rad{};
  std::array<double, kDriveCount> velocity_rad_s{};
  std::array<std::uint16_t, kDriveCount> statusword{};
  std::uint8_t sync_counter = 0;  // the SYNC these values answer (0 = none yet)
  SteadyTime sync_time{};         // when that SYNC was sent (steady_clock = CLOCK_MONOTONIC)
  std::uint64_t cycle = 0;        // cycle number of that SYNC, counting from 1
  bool complete = false;          // all 7 drives answered that SYNC
};

struct Wrench {
  std::array<double, 6> values{};  // Fx Fy Fz [N], Tx Ty Tz [N·m], in the sensor frame
  std::uint8_t sync_counter = 0;   // the SYNC the force and torque frames answer (0 = none yet)
  SteadyTime sync_time{};
  std::uint64_t sequence = 0;      // increments with each complete wrench (force + torque)
  bool valid = false;
};

enum class FaultKind : std::uint8_t {
  none,
  drive_fault,        // statusword reports fault / fault reaction
  drive_disabled,     // a drive left operation enabled by itself
  emergency,          // EMCY with a non-zero error code
  heartbeat_lost,     // a node silent longer than heartbeat_timeout
  bus_error,          // the transport failed
  missing_feedback,   // a drive did not answer several SYNCs in a row
  node_not_operational,  // a heartbeat reports boot-up/stopped/pre-operational after start
  cycle_owner_lost,   // the thread that took the cycles over stopped running them
};
std::string_view to_string(FaultKind kind);

struct MasterFault {
  FaultKind kind = FaultKind::none;
  std::uint8_t node = 0;           // the node concerned (0 = bus / none)
  std::uint16_t code = 0;          // EMCY code or statusword
  std::string reason;              // e.g. "drive 4 (E1): EMCY 0x8250 RPDO timeout (command loss)"
  bool active() const { return kind != FaultKind::none; }
};

struct MasterCounters {
  std::uint64_t cycles = 0;            // SYNCs sent
  std::uint64_t overruns = 0;          // run_periodic: cycle found its deadline already past
  std::uint64_t step_timeouts = 0;     // step(): not all expected TPDOs within step_timeout
  std::uint64_t malformed_frames = 0;  // protocol id, but the decoder refused it
  std::uint64_t unknown_frames = 0;    // id outside the protocol
  std::uint64_t late_frames = 0;       // TPDO answering an older SYNC: ignored
  std::uint64_t foreign_frames = 0;    // master-side frames (SYNC, NMT, RPDO, SDO request) from another master
  std::uint64_t emcy_frames = 0;
  std::uint64_t send_dropped = 0;      // transmit queue full
};

class Pa10Master {
 public:
  // `sensor_bus` may be null: the sensors are then read from `drive_bus`. The master owns both.
  Pa10Master(std::unique_ptr<Bus> drive_bus, std::unique_ptr<Bus> sensor_bus,
             MasterConfig config = {});
  // Opens the buses by spec (see open_bus); an empty `sensor_bus_spec` means the same bus.
  Pa10Master(std::string_view drive_bus_spec, std::string_view sensor_bus_spec,
             MasterConfig config = {});
  // Stops the periodic thread, then sends one last zero-velocity "shutdown" cycle and NMT
  // enter pre-operational, so the drives brake and do not time out into fault.
  ~Pa10Master();
  Pa10Master(const Pa10Master&) = delete;
  Pa10Master& operator=(const Pa10Master&) = delete;

  // Startup: wait for boot-up or heartbeat of every drive and configured sensor (error names
  // the missing nodes), NMT enter pre-operational, SDO 0x6060:00 = 9 to each drive and check
  // 0x6061:00 reads 9, NMT start all, then cycle (paced at `period`) until every drive
  // reports operation enabled (shutdown -> switch on -> enable operation, each on the drive's
  // own statusword). Throws std::runtime_error with the bus name and the failing node/step.
  void start();

  // Lock-step: one cycle (read the previous answers, write RPDOs, send SYNC), then wait until
  // every drive and configured sensor answered this SYNC or step_timeout passed. Returns true
  // when all answered. Must not be used while run_periodic() runs.
  bool step();

  // Own thread: one cycle per `period` on an absolute CLOCK_MONOTONIC schedule; a cycle that
  // starts after its deadline counts an overrun and the schedule skips ahead (no burst).
  void run_periodic();
  void run_periodic(std::chrono::nanoseconds period);  // same, with this SYNC period
  void stop();  // stops run_periodic's thread; idempotent
  bool running() const { return running_.load(); }

  // Joint velocity targets [rad/s] for the next cycle. Thread-safe, no allocation. Throws
  // std::invalid_argument for a NaN or infinite value (nothing is applied then). Ignored
  // (zero is sent) while a fault is active. Ends a quick_stop(). Each accepted target gets the
  // next target sequence number (from 1), returned; 0 when ignored.
  std::uint64_t set_target_velocities(const std::array<double, kDriveCount>& velocity_rad_s);
  // Sequence number of the last accepted target (0 = none yet).
  std::uint64_t target_sequence() const;

  // The last target that left for the bus: published by the cycle right after it has written
  // the seven RPDOs carrying it (one write with the SYNC behind them), with the CLOCK_REALTIME
  // time of that write (the clock sensor
  // samples are stamped with), so sent_realtime_ns - a sample's stamp is the end-to-end
  // latency. {0, 0} until a target has been sent; cycles sending zero instead (fault, quick
  // stop, enabling) leave it unchanged.
  struct SentTarget {
    std::uint64_t sequence = 0;
    std::int64_t sent_realtime_ns = 0;
  };
  SentTarget last_sent() const;

  // ---- Cycles run by another thread ----------------------------------------------------
  // A caller with a periodic thread of its own (a shared tick running sensor -> controller ->
  // actuator) can run the SYNC cycle in two halves around its work, so a command computed from
  // the freshest answers leaves with the very next SYNC, with no second thread to wake:
  //   receive_cycle()   the answers to the previous SYNC are closed and published
  //                     (joint_state(), wrench(), fault()), heartbeats checked;
  //   transmit_cycle()  the latest target goes out in the 7 RPDOs (last_sent() published),
  //                     then SYNC.
  // Call them in that order once per period, from one thread. A bus error latches a fault
  // (they do not throw it); calling them without the cycles taken over is a std::logic_error.
  // They return false, doing nothing, once run_periodic()'s thread has taken the cycles back
  // because the caller stopped sending SYNC (MasterConfig::taken_over_timeout_periods).
  //
  // take_over_cycles(): run_periodic()'s thread finishes the cycle it is in and idles; returns
  // the CLOCK_MONOTONIC deadline [ns] it would have cycled next: the caller's first cycle is
  // due then, so no SYNC is lost or doubled. Waits at most one period; returns 0 at once when
  // no periodic thread runs. Idempotent.
  // hand_back_cycles(next_deadline_ns): the thread cycles again, first at next_deadline_ns
  // (0 = now; a deadline more than a period past moves forward on its grid). Waits until the
  // thread has it. No-op unless taken over.
  // If the caller stops cycling without handing back, the drives' RPDO timeout brakes them.
  std::int64_t take_over_cycles();
  void hand_back_cycles(std::int64_t next_deadline_ns);
  bool cycles_taken_over() const;
  bool receive_cycle();
  bool transmit_cycle();

  // run_periodic()'s grid: the CLOCK_MONOTONIC deadline [ns] of its next cycle (cycles follow
  // every period from there); 0 when the periodic thread does not run or its cycles are taken
  // over. For phasing another periodic activity against the SYNC cycles.
  std::int64_t next_cycle_deadline_ns() const;
  std::chrono::nanoseconds period() const;

  JointState joint_state() const;
  Wrench wrench(ForceSensor sensor) const;
  MasterFault fault() const;
  // Every drive in operation enabled (or quick stop active after quick_stop()) and no fault.
  bool enabled() const;

  // Brakes every drive (CiA 402 quick stop) from the next cycle on and keeps them braked until
  // set_target_velocities() or fault_reset(). Thread-safe, no allocation. Ignored while a fault
  // is active (the fault already holds zero). enabled() stays true meanwhile: the drives are
  // ready to move again on the next target.
  void quick_stop();
  // True once every drive reports quick stop active for a quick_stop() still in force.
  bool quick_stopped() const;

  // Clears the latched fault and makes the next cycles send the fault-reset edge and the
  // enable sequence to every drive not in operation enabled. Asynchronous: with run_periodic()
  // it happens on the thread; with step() on the next steps. Targets stay zero until set again.
  // If drives are not all enabled again within enable_timeout, the fault is raised again.
  void fault_reset();

  MasterCounters counters() const;
  const std::string& drive_bus_name() const;
  const std::string& sensor_bus_name() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::atomic<bool> running_{false};
  std::atomic<std::int64_t> next_cycle_deadline_ns_{0};
  std::thread thread_;

  // Who runs the cycles: own -> requested (take_over waits) -> external (the thread idles) ->
  // returning (hand_back waits) -> own.
  enum class Handover : std::uint8_t { own, requested, external, returning };
  std::mutex handover_mutex_;
  std::condition_variable handover_cv_;
  Handover handover_ = Handover::own;
  std::int64_t handover_deadline_ns_ = 0;
  std::atomic<bool> external_{false};
  std::atomic<bool> reclaimed_{false};          // taken back from a silent owner
  std::atomic<std::uint64_t> transmits_{0};     // transmit_cycle() calls, for the idle thread
  std::mutex cycle_mutex_;  // whoever runs (half) a cycle; uncontended unless taking back
  void publish_deadline(SteadyTime next);
  bool idle_while_taken_over(SteadyTime& next);
  bool run_half_cycle(const char* what, void (Impl::*half)());
};

}  // namespace rtm::can
