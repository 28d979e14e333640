// SPDX-License-Identifier: Apache-2.0
#include "rt/activity.h"

#include <stdexcept>

#include "rt/clock.h"

namespace rtm {

namespace {

// Sleeps until deadline_ns (absolute, CLOCK_MONOTONIC) in slices of at most 50 ms so that a
// stop request is seen within 50 ms even with long periods. False when stopped.
bool sleep_until(std::int64_t deadline_ns, const std::atomic<bool>& stop) {
  constexpr std::int64_t kSlice_ns = 50'000'000;
  while (!stop.load(std::memory_order_relaxed)) {
    const std::int64_t now = monotonic_ns();
    if (now >= deadline_ns) return true;
    const std::int64_t target = deadline_ns - now > kSlice_ns ? now + kSlice_ns : deadline_ns;
    sleep_until_ns(target);
  }
  return false;
}

// start()/stop() shared by the thread-owning activities.
// prepare() runs under the lock just before the thread starts, only when it does.
template <class Body, class Prepare>
void start_thread(std::mutex& mu, std::thread& thread, std::atomic<bool>& stop_requested,
                  std::atomic<bool>& running, Body body, Prepare prepare) {
  std::lock_guard lock(mu);
  if (running.load() && !stop_requested.load()) return;
  if (thread.joinable()) {
    if (thread.get_id() == std::this_thread::get_id())
      throw std::logic_error("rtm: an activity cannot restart itself from its own cycle");
    thread.join();
  }
  prepare();
  stop_requested.store(false);
  running.store(true);
  thread = std::thread(std::move(body));
}

void stop_thread(std::mutex& mu, std::thread& thread, std::atomic<bool>& stop_requested) {
  stop_requested.store(true);
  std::lock_guard lock(mu);
  if (thread.joinable()) thread.join();
}

}  // namespace

// ============================ PeriodicActivity ========================

PeriodicActivity::PeriodicActivity(CycleFunction cycle, PeriodicOptions options)
    // The schedule checks the period and the catch-up window (std::invalid_argument).
    : cycle_(std::move(cycle)), options_(std::move(options)), schedule_(options_.period_ns, options_.catch_up_ns) {
  if (!cycle_) throw std::invalid_argument("PeriodicActivity: empty cycle function");
  if (options_.first_deadline_ns < 0)
    throw std::invalid_argument("PeriodicActivity: first_deadline_ns must be >= 0 (0: at once), got " +
                                std::to_string(options_.first_deadline_ns));
}

PeriodicActivity::~PeriodicActivity() { stop(); }

void PeriodicActivity::set_first_deadline_ns(std::int64_t first_deadline_ns) {
  if (first_deadline_ns < 0)
    throw std::invalid_argument("PeriodicActivity: first_deadline_ns must be >= 0 (0: at once), got " +
                                std::to_string(first_deadline_ns));
  std::lock_guard lock(control_mu_);
  if (running_.load()) throw std::logic_error("PeriodicActivity::set_first_deadline_ns while running; stop it first");
  options_.first_deadline_ns = first_deadline_ns;
}

void PeriodicActivity::start() {
  // The first deadline is fixed here, not on the new thread: next_deadline_ns() is right as
  // soon as start() returns.
  start_thread(control_mu_, thread_, stop_requested_, running_, [this] { loop(); },
               [this] { schedule_.start(options_.first_deadline_ns, monotonic_ns()); });
}

void PeriodicActivity::stop() {
  // From inside a cycle only request the stop: the caller IS the thread to be joined, and a
  // stop() in another thread may hold control_mu_ while joining it.
  if (own_thread_id_.load() == std::this_thread::get_id()) {
    stop_requested_.store(true);
    return;
  }
  stop_thread(control_mu_, thread_, stop_requested_);
}

std::int64_t PeriodicActivity::stop_after_cycle() {
  if (own_thread_id_.load() == std::this_thread::get_id())
    throw std::logic_error("PeriodicActivity::stop_after_cycle from the activity's own cycle");
  std::lock_guard lock(control_mu_);
  if (thread_.joinable()) {
    stop_after_cycle_.store(true);
    thread_.join();  // the thread ends after its next cycle (stop_requested_ untouched: it runs)
    stop_after_cycle_.store(false);
  }
  return schedule_.deadline_ns();
}

bool PeriodicActivity::running() const { return running_.load(); }

ActivityStats PeriodicActivity::stats() const { return schedule_.stats(); }

void PeriodicActivity::loop() {
  own_thread_id_.store(std::this_thread::get_id());
  apply_thread_settings(options_.thread_settings());
  while (sleep_until(schedule_.deadline_ns(), stop_requested_)) {
    const bool keep_running = cycle_(schedule_.begin(monotonic_ns()));
    schedule_.end(monotonic_ns());
    if (!keep_running || stop_after_cycle_.load()) break;
  }
  own_thread_id_.store(std::thread::id());
  running_.store(false);
}

// ============================ ArrivalSignal ===========================

void ArrivalSignal::notify() {
  {
    std::lock_guard lock(mu_);
    ++count_;
  }
  cv_.notify_all();
}

bool ArrivalSignal::wait(std::uint64_t& seen, std::int64_t timeout_ns, const std::atomic<bool>* cancel) {
  std::unique_lock lock(mu_);
  cv_.wait_for(lock, std::chrono::nanoseconds(timeout_ns),
               [&] { return count_ != seen || (cancel && cancel->load()); });
  if (count_ == seen) return false;
  seen = count_;
  return true;
}

void ArrivalSignal::wake_waiters() {
  { std::lock_guard lock(mu_); }
  cv_.notify_all();
}

std::uint64_t ArrivalSignal::count() const {
  std::lock_guard lock(mu_);
  return count_;
}

// ============================ OnArrivalActivity =======================

OnArrivalActivity::OnArrivalActivity(CycleFunction cycle, std::shared_ptr<ArrivalSignal> signal,
                                     std::string thread_name)
    : cycle_(std::move(cycle)), signal_(std::move(signal)), thread_name_(std::move(thread_name)) {
  if (!cycle_) throw std::invalid_argument("OnArrivalActivity: empty cycle function");
  if (!signal_) throw std::invalid_argument("OnArrivalActivity: no arrival signal");
}

OnArrivalActivity::~OnArrivalActivity() { stop(); }

void OnArrivalActivity::start() {
  // Counted here, not in the new thread: a datum put between start() and the thread's first
  // look (a slow thread start on a loaded machine) must still wake it.
  const std::uint64_t seen = signal_->count();
  start_thread(control_mu_, thread_, stop_requested_, running_, [this, seen] { loop(seen); }, [] {});
}

void OnArrivalActivity::stop() {
  if (own_thread_id_.load() == std::this_thread::get_id()) {
    stop_requested_.store(true);
    return;
  }
  stop_requested_.store(true);
  signal_->wake_waiters();
  stop_thread(control_mu_, thread_, stop_requested_);
}

bool OnArrivalActivity::running() const { return running_.load(); }

ActivityStats OnArrivalActivity::stats() const {
  ActivityStats s;
  s.cycles = cycles_.load(std::memory_order_relaxed);
  return s;
}

void OnArrivalActivity::loop(std::uint64_t seen) {
  own_thread_id_.store(std::this_thread::get_id());
  set_thread_name(thread_name_);
  std::uint64_t cycle = 0;
  while (!stop_requested_.load()) {
    if (!signal_->wait(seen, 50'000'000, &stop_requested_)) continue;
    if (stop_requested_.load()) break;
    const std::int64_t wake = monotonic_ns();
    const CycleContext ctx{cycle++, wake, wake, 0};
    const bool keep_running = cycle_(ctx);
    cycles_.fetch_add(1, std::memory_order_relaxed);
    if (!keep_running) break;
  }
  own_thread_id_.store(std::thread::id());
  running_.store(false);
}

// ============================ SharedTick ==============================

SharedTick::SharedTick(PeriodicOptions options)
    : activity_(
          [this](const CycleContext& ctx) {
            for (auto& cycle : cycles_)
              if (!cycle(ctx)) return false;
            return true;
          },
          std::move(options)) {}

SharedTick::~SharedTick() { activity_.stop(); }

void SharedTick::add(CycleFunction cycle) {
  if (!cycle) throw std::invalid_argument("SharedTick::add: empty cycle function");
  if (activity_.running()) throw std::logic_error("SharedTick::add: the tick is running; stop it first");
  cycles_.push_back(std::move(cycle));
}

void SharedTick::start() { activity_.start(); }
void SharedTick::stop() { activity_.stop(); }
bool SharedTick::running() const { return activity_.running(); }
ActivityStats SharedTick::stats() const { return activity_.stats(); }

}  // namespace rtm
