// SPDX-License-Identifier: Apache-2.0
#include "arm/can/master.h"

#include <cmath>
#include <stdexcept>

#include "arm/can/bus_cycle.h"
#include "arm/can/startup.h"

namespace rtm::can {

Pa10Master::Pa10Master(std::unique_ptr<Bus> drive_bus, std::unique_ptr<Bus> sensor_bus, MasterConfig config)
    : cycle_(std::make_unique<BusCycle>(std::move(drive_bus), std::move(sensor_bus), std::move(config))) {}

Pa10Master::Pa10Master(std::string_view drive_bus_spec, std::string_view sensor_bus_spec, MasterConfig config)
    : Pa10Master(open_bus(drive_bus_spec),
                 sensor_bus_spec.empty() || sensor_bus_spec == drive_bus_spec ? nullptr : open_bus(sensor_bus_spec),
                 std::move(config)) {}

Pa10Master::~Pa10Master() {
  stop();
  if (!cycle_->supervisor().started()) return;
  try {
    cycle_->shutdown();
  } catch (const std::exception&) {
    // The bus is gone: the drives' own RPDO timeout brakes them.
  }
}

void Pa10Master::start() { run_startup(*cycle_); }

bool Pa10Master::step() {
  if (periodic_.load()) throw std::logic_error("Pa10Master::step() while run_periodic() runs");
  if (external_.load()) throw std::logic_error("Pa10Master::step() while its cycles are taken over");
  if (!cycle_->supervisor().started()) throw std::logic_error("Pa10Master::step() before start()");
  try {
    return cycle_->step();
  } catch (const BusError& e) {
    cycle_->bus_failure(e);
    return false;
  }
}

// ---- who owns time --------------------------------------------------------------------------

// One cycle of the master's own activity.
bool Pa10Master::own_cycle() {
  std::lock_guard cycle(cycle_mutex_);
  try {
    const std::int64_t now_ns = monotonic_ns();
    cycle_->receive(now_ns);
    cycle_->transmit(now_ns);
  } catch (const BusError& e) {
    cycle_->bus_failure(e);
  }
  return true;
}

void Pa10Master::start_own(std::int64_t first_deadline_ns) {
  own_->set_first_deadline_ns(first_deadline_ns);
  own_->start();
}

void Pa10Master::run_periodic() {
  if (!cycle_->supervisor().started()) throw std::logic_error("Pa10Master::run_periodic() before start()");
  std::lock_guard lock(handover_mutex_);
  if (external_.load()) throw std::logic_error("Pa10Master::run_periodic() while its cycles are taken over");
  if (periodic_.load()) return;
  const MasterConfig& config = cycle_->config();
  if (!own_ || own_->options().period_ns != config.period_ns) {
    rtm::PeriodicOptions options;
    options.period_ns = config.period_ns;
    options.fifo_priority = config.realtime_priority;
    options.cpu = config.cpu;
    options.thread_name = "pa10-master";
    own_ = std::make_unique<rtm::PeriodicActivity>([this](const rtm::CycleContext&) { return own_cycle(); }, options);
  }
  reclaimed_.store(false);
  periodic_.store(true);
  start_own(config.first_deadline_ns);
}

void Pa10Master::run_periodic(std::int64_t period_ns) {
  if (period_ns <= 0) throw std::invalid_argument("Pa10Master::run_periodic: period must be > 0");
  if (periodic_.load()) throw std::logic_error("Pa10Master::run_periodic(period) while already running");
  cycle_->set_period_ns(period_ns);
  run_periodic();
}

void Pa10Master::stop() {
  // The watchdog first: it may start the master's activity as it takes the cycles back.
  if (watchdog_) watchdog_->stop();
  std::lock_guard lock(handover_mutex_);
  periodic_.store(false);
  if (own_) own_->stop();
}

std::int64_t Pa10Master::take_over_cycles() {
  if (!cycle_->supervisor().started()) throw std::logic_error("Pa10Master::take_over_cycles() before start()");
  std::lock_guard lock(handover_mutex_);
  if (external_.load()) return handover_deadline_ns_;
  handover_deadline_ns_ = 0;
  if (periodic_.load() && own_) {
    // The master's activity runs the cycle in progress (or its next one) and ends: the first
    // deadline it did not run, about a period ahead, is the caller's first.
    handover_deadline_ns_ = own_->stop_after_cycle();
  }
  reclaimed_.store(false);
  external_.store(true, std::memory_order_release);
  const int timeout = cycle_->config().taken_over_timeout_periods;
  if (periodic_.load() && timeout > 0) {
    // One check per period, half a period after each of the caller's deadlines from its
    // second on: its cycle is done by then, and the watchdog never wakes with it.
    const MasterConfig& config = cycle_->config();
    rtm::PeriodicOptions options;
    options.period_ns = config.period_ns;
    options.thread_name = "pa10-syncwatch";
    // At the master's priority: beside ordinary work it still wakes on time, so a tick that
    // sends no SYNC is told from a stall of the whole host (when this thread is late too).
    options.fifo_priority = config.realtime_priority;
    options.first_deadline_ns =
        (handover_deadline_ns_ > 0 ? handover_deadline_ns_ : monotonic_ns()) + options.period_ns + options.period_ns / 2;
    silent_periods_ = 0;
    transmits_seen_ = transmits_.load();
    watchdog_ = std::make_unique<rtm::PeriodicActivity>(
        [this](const rtm::CycleContext& ctx) { return watch_owner(ctx); }, options);
    watchdog_->start();
  }
  return handover_deadline_ns_;
}

// The SYNC watchdog, once per period while the cycles are the caller's: a caller that sends no
// SYNC for taken_over_timeout_periods periods in which the watchdog itself woke on time (so
// not a stall of the whole process or host) loses them to the master's own activity, with
// FaultKind::cycle_owner_lost. Returns false once it has taken them back.
bool Pa10Master::watch_owner(const rtm::CycleContext& ctx) {
  const std::uint64_t transmits = transmits_.load();
  if (transmits != transmits_seen_) {
    transmits_seen_ = transmits;
    silent_periods_ = 0;
  } else if (ctx.wake_ns - ctx.deadline_ns < ctx.period_ns / 2) {
    ++silent_periods_;
  } else {
    silent_periods_ = 0;  // the watchdog was late too: a stall of the process or host, not the owner alone
  }
  if (silent_periods_ < cycle_->config().taken_over_timeout_periods) return true;
  std::unique_lock handover(handover_mutex_, std::try_to_lock);
  if (!handover.owns_lock()) return true;  // a hand-back or stop() is under way
  std::unique_lock cycle(cycle_mutex_, std::try_to_lock);
  if (!cycle.owns_lock()) return true;  // the owner is inside a half cycle: let it finish
  external_.store(false, std::memory_order_release);
  reclaimed_.store(true);
  cycle_->supervisor().latch(FaultKind::cycle_owner_lost, 0, 0,
                             "the thread running the bus cycles sent no SYNC for %d periods: the master's own thread "
                             "took them back",
                             silent_periods_);
  cycle.unlock();
  // On the owner's grid (this watchdog wakes half a period after each of its deadlines), so an
  // owner that takes the cycles again goes on where the master's thread stops.
  start_own(ctx.deadline_ns + ctx.period_ns / 2);
  return false;
}

void Pa10Master::hand_back_cycles(std::int64_t next_deadline_ns) {
  if (watchdog_) watchdog_->stop();
  std::lock_guard lock(handover_mutex_);
  if (!external_.load()) return;
  external_.store(false, std::memory_order_release);
  if (!periodic_.load()) return;  // nobody to hand back to: the cycles simply stop being the caller's
  start_own(next_deadline_ns);
}

bool Pa10Master::cycles_taken_over() const { return external_.load(std::memory_order_acquire); }

bool Pa10Master::run_half_cycle(const char* what, void (BusCycle::*half)(std::int64_t)) {
  std::lock_guard cycle(cycle_mutex_);
  if (!external_.load(std::memory_order_acquire)) {
    if (reclaimed_.load()) return false;
    throw std::logic_error(std::string("Pa10Master::") + what + "() without take_over_cycles()");
  }
  try {
    (cycle_.get()->*half)(monotonic_ns());
  } catch (const BusError& e) {
    cycle_->bus_failure(e);
  }
  return true;
}

bool Pa10Master::receive_cycle() { return run_half_cycle("receive_cycle", &BusCycle::receive); }

bool Pa10Master::transmit_cycle() {
  const bool mine = run_half_cycle("transmit_cycle", &BusCycle::transmit);
  if (mine) transmits_.fetch_add(1);
  return mine;
}

std::int64_t Pa10Master::next_cycle_deadline_ns() const {
  if (!periodic_.load() || external_.load() || !own_) return 0;
  return own_->next_deadline_ns();
}

std::int64_t Pa10Master::period_ns() const { return cycle_->config().period_ns; }

// ---- the mailbox ----------------------------------------------------------------------------

std::uint64_t Pa10Master::target_sequence() const {
  return cycle_->mailbox().with_requests([](CycleRequests& r, const CycleReport&) { return r.target_sequence; });
}

Pa10Master::SentTarget Pa10Master::last_sent() const {
  return cycle_->mailbox().with_report([](const CycleReport& r) { return r.last_sent; });
}

std::uint64_t Pa10Master::set_target_velocities(const std::array<double, kDriveCount>& velocity_rad_s) {
  for (int j = 0; j < kDriveCount; ++j) {
    if (!std::isfinite(velocity_rad_s[static_cast<std::size_t>(j)])) {
      throw std::invalid_argument("Pa10Master::set_target_velocities: joint " +
                                  std::string(joint_name(j)) + " velocity is not finite");
    }
  }
  return cycle_->mailbox().with_requests([&](CycleRequests& r, const CycleReport& report) -> std::uint64_t {
    if (report.fault.active()) return 0;
    r.target_rad_s = velocity_rad_s;
    r.target_valid = true;
    r.quick_stop = false;
    return ++r.target_sequence;
  });
}

void Pa10Master::quick_stop() {
  cycle_->mailbox().with_requests([](CycleRequests& r, const CycleReport& report) {
    if (report.fault.active()) return;
    r.quick_stop = true;
    r.target_valid = false;
  });
}

bool Pa10Master::quick_stopped() const {
  return cycle_->mailbox().with_report([](const CycleReport& r) { return r.quick_stopped; });
}

JointState Pa10Master::joint_state() const {
  return cycle_->mailbox().with_report([](const CycleReport& r) { return r.state; });
}

Wrench Pa10Master::wrench(ForceSensor sensor) const {
  return cycle_->mailbox().with_report([sensor](const CycleReport& r) { return r.wrench[sensor_slot(sensor)]; });
}

MasterFault Pa10Master::fault() const {
  const FaultRecord record = cycle_->mailbox().with_report([](const CycleReport& r) { return r.fault; });
  return MasterFault{record.kind, record.node, record.code, std::string(record.reason.data())};
}

bool Pa10Master::enabled() const {
  return cycle_->mailbox().with_report([](const CycleReport& r) { return r.enabled; });
}

void Pa10Master::fault_reset() {
  cycle_->mailbox().with_requests([](CycleRequests& r, const CycleReport&) {
    r.fault_reset = true;
    r.target_valid = false;
    r.quick_stop = false;
  });
}

MasterCounters Pa10Master::counters() const {
  MasterCounters counters = cycle_->mailbox().with_report([](const CycleReport& r) { return r.counters; });
  if (own_) counters.overruns = own_->stats().overruns;
  return counters;
}

const std::string& Pa10Master::drive_bus_name() const { return cycle_->drive_bus().name(); }
const std::string& Pa10Master::sensor_bus_name() const { return cycle_->sensor_bus().name(); }

}  // namespace rtm::can
