// SPDX-License-Identifier: Apache-2.0
// Pa10Master: the CANopen master of the PA10 - NMT master, SYNC producer, PDO exchange with
// the 7 drives and reception of the two force sensors.
//
// Use: construct (buses open), start() (startup sequence, blocking, throws on failure), then
// either run_periodic() (own thread, absolute 2 ms schedule) or step() per cycle (lock-step:
// e.g. driven by a simulator clock); a periodic caller may take run_periodic()'s cycles over
// and run them itself (take_over_cycles(), receive_cycle(), transmit_cycle()). From any
// thread: set_target_velocities(), joint_state(), wrench(), fault(), fault_reset(), counters().
//
// The parts (one file each): BusCycle (bus_cycle.h) is the SYNC cycle with no thread:
// receive(now) / transmit(now); Supervisor (supervisor.h) latches faults, holds quick stops
// and watches heartbeats and feedback; run_startup() (startup.h) is the start-up sequence.
// This class owns them and decides who runs the cycle: its own PeriodicActivity (rt/), a
// caller's thread (take_over_cycles()) watched by a small SYNC watchdog, or step() callers.
// The cycle does no allocation, no logging, no I/O other than the CAN frames; other threads
// reach it through its Mailbox, a mutex held only for copies, never across a send or a wait.
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
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>

#include "arm/can/bus.h"
#include "arm/can/master_types.h"
#include "rt/activity.h"
#include "rt/tick_stage.h"

namespace rtm::can {

class BusCycle;

class Pa10Master final : public rtm::TickStage {
 public:
  // `sensor_bus` may be null: the sensors are then read from `drive_bus`. The master owns both.
  Pa10Master(std::unique_ptr<Bus> drive_bus, std::unique_ptr<Bus> sensor_bus,
             MasterConfig config = {});
  // Opens the buses by spec (see open_bus); an empty `sensor_bus_spec` means the same bus.
  Pa10Master(std::string_view drive_bus_spec, std::string_view sensor_bus_spec,
             MasterConfig config = {});
  // Stops the periodic thread, then sends one last zero-velocity "shutdown" cycle and NMT
  // enter pre-operational, so the drives brake and do not time out into fault.
  ~Pa10Master() override;
  Pa10Master(const Pa10Master&) = delete;
  Pa10Master& operator=(const Pa10Master&) = delete;

  // Startup: wait for boot-up or heartbeat of every drive and configured sensor (error names
  // the missing nodes), NMT enter pre-operational, SDO 0x6060:00 = 9 to each drive and check
  // 0x6061:00 reads 9, NMT start all, then cycle (paced at `period_ns`) until every drive
  // reports operation enabled (shutdown -> switch on -> enable operation, each on the drive's
  // own statusword). Throws std::runtime_error with the bus name and the failing node/step.
  void start();

  // Lock-step: one cycle (read the previous answers, write RPDOs, send SYNC), then wait until
  // every drive and configured sensor answered this SYNC or step_timeout_ns passed. Returns true
  // when all answered. Must not be used while run_periodic() runs.
  bool step();

  // Own thread: one cycle per `period_ns` on a PeriodicActivity (rt/activity.h: an absolute
  // CLOCK_MONOTONIC grid; a cycle that ends a period late counts an overrun and the schedule
  // skips ahead on the grid, no burst). Thread settings from MasterConfig (realtime_priority,
  // cpu).
  void run_periodic();
  void run_periodic(std::int64_t period_ns);  // same, with this SYNC period [ns]
  void stop();  // stops run_periodic's thread; idempotent
  bool running() const { return periodic_.load(); }

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
  using SentTarget = can::SentTarget;
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
  // They return false, doing nothing, once the watchdog has given the cycles back to the
  // master's activity because the caller stopped sending SYNC
  // (MasterConfig::taken_over_timeout_periods).
  //
  // take_over_cycles(): the master's own activity stops after the cycle it is in; returns the
  // CLOCK_MONOTONIC deadline [ns] it would have cycled next: the caller's first cycle is due
  // then, so no SYNC is lost or doubled. Waits at most one period; returns 0 at once when no
  // periodic thread runs. Idempotent. From then on a SYNC watchdog checks once per period that
  // the caller transmits.
  // hand_back_cycles(next_deadline_ns): the watchdog stops and the master's activity starts
  // again, first at next_deadline_ns (0 = now; a deadline already past moves forward on its
  // grid). No-op unless taken over.
  // If the caller stops cycling without handing back, the drives' RPDO timeout brakes them.
  std::int64_t take_over_cycles();
  void hand_back_cycles(std::int64_t next_deadline_ns);
  bool cycles_taken_over() const;
  bool receive_cycle();
  bool transmit_cycle();
  // The same, as a shared tick's stage (rt/tick_stage.h).
  std::int64_t take_over() override { return take_over_cycles(); }
  void hand_back(std::int64_t next_deadline_ns) override { hand_back_cycles(next_deadline_ns); }
  bool receive(std::int64_t) override { return receive_cycle(); }
  bool transmit(std::int64_t) override { return transmit_cycle(); }

  // run_periodic()'s grid: the CLOCK_MONOTONIC deadline [ns] of its next cycle (cycles follow
  // every period from there); 0 when the periodic thread does not run or its cycles are taken
  // over. For phasing another periodic activity against the SYNC cycles.
  std::int64_t next_cycle_deadline_ns() const;
  std::int64_t period_ns() const;  // the SYNC period

  JointState joint_state() const;
  Wrench wrench(ForceSensor sensor) const;
  MasterFault fault() const;
  // Every drive in operation enabled (or quick stop active after quick_stop()) and no fault,
  // on each drive's latest statusword: a TPDO that comes a cycle late (a host stall) does not
  // clear it; a drive silent for more than missed_feedback_limit SYNCs is a fault, which does.
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
  // If drives are not all enabled again within enable_timeout_ns, the fault is raised again.
  void fault_reset();

  MasterCounters counters() const;
  const std::string& drive_bus_name() const;
  const std::string& sensor_bus_name() const;

 private:
  std::unique_ptr<BusCycle> cycle_;
  // Whoever runs (half) a cycle holds it: uncontended unless the watchdog takes the cycles back.
  std::mutex cycle_mutex_;
  // Who owns time. periodic_: run_periodic() was called and stop() was not. external_: the
  // cycles are the caller's (take_over_cycles()); own_ is then stopped and the watchdog runs.
  std::mutex handover_mutex_;  // serialises run_periodic/stop/take_over/hand_back and the watchdog's take-back
  std::atomic<bool> periodic_{false};
  std::atomic<bool> external_{false};
  std::atomic<bool> reclaimed_{false};        // taken back from a silent owner
  std::int64_t handover_deadline_ns_ = 0;     // the caller's first cycle
  std::atomic<std::uint64_t> transmits_{0};  // transmit_cycle() calls, for the watchdog
  std::unique_ptr<rtm::PeriodicActivity> own_;       // the master's own cycles
  std::unique_ptr<rtm::PeriodicActivity> watchdog_;  // the SYNC watchdog while taken over
  int silent_periods_ = 0;
  std::uint64_t transmits_seen_ = 0;

  bool own_cycle();
  bool watch_owner(const rtm::CycleContext& ctx);
  void start_own(std::int64_t first_deadline_ns);
  bool run_half_cycle(const char* what, void (BusCycle::*half)(std::int64_t));
};

}  // namespace rtm::can
