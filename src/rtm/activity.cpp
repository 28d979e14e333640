#include "rtm/activity.h"

#include "rtm/data.h"
#include "rtm/log.h"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <time.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace rtm {

// ============================ schedule arithmetic =====================

ScheduleStep next_deadline(std::int64_t deadline_ns, std::int64_t period_ns, std::int64_t now_ns) {
  const std::int64_t next = deadline_ns + period_ns;
  if (now_ns - next < period_ns) return {next, 0, false};
  const std::int64_t missed = (now_ns - deadline_ns) / period_ns;
  return {deadline_ns + (missed + 1) * period_ns, static_cast<std::uint64_t>(missed), true};
}

std::int64_t grid_point_at_or_after(std::int64_t origin_ns, std::int64_t period_ns, std::int64_t now_ns) {
  if (period_ns <= 0) throw std::invalid_argument("grid_point_at_or_after: period_ns must be > 0");
  // Floor division, so an origin after now_ns steps back as well as forward.
  const std::int64_t offset = now_ns - origin_ns;
  std::int64_t periods = offset / period_ns;
  if (offset % period_ns != 0 && offset < 0) --periods;
  std::int64_t point = origin_ns + periods * period_ns;
  if (point < now_ns) point += period_ns;
  return point;
}

std::int64_t first_deadline(std::int64_t requested_ns, std::int64_t period_ns, std::int64_t now_ns) {
  if (requested_ns == 0 || requested_ns >= now_ns) return requested_ns == 0 ? now_ns : requested_ns;
  return grid_point_at_or_after(requested_ns, period_ns, now_ns);
}

// ============================ thread settings =========================

namespace {

void set_thread_name(const std::string& name) {
  pthread_setname_np(pthread_self(), name.substr(0, 15).c_str());
}

// Privileged settings degrade to a warning: a developer machine without CAP_SYS_NICE must
// still run the whole system, only with worse timing.
void apply_periodic_settings(const PeriodicOptions& options) {
  // Default slack makes SCHED_OTHER threads wake ~50 us late.
  prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);
  set_thread_name(options.thread_name);
  if (options.cpu >= 0) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(options.cpu, &set);
    if (int err = pthread_setaffinity_np(pthread_self(), sizeof(set), &set); err != 0)
      log().warn("{}: cannot pin to CPU {} ({}); running unpinned", options.thread_name, options.cpu,
                 std::strerror(err));
  }
  if (options.fifo_priority > 0) {
    sched_param param{};
    param.sched_priority = options.fifo_priority;
    if (int err = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param); err != 0)
      log().warn("{}: SCHED_FIFO priority {} refused ({}); running SCHED_OTHER{}", options.thread_name,
                 options.fifo_priority, std::strerror(err),
                 err == EPERM ? " (needs CAP_SYS_NICE or an rtprio limit)" : "");
  }
  if (options.lock_memory) {
    if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0)
      log().warn("{}: mlockall refused ({}); page faults may delay cycles", options.thread_name,
                 std::strerror(errno));
  }
}

// Sleeps until deadline_ns (absolute, CLOCK_MONOTONIC) in slices of at most 50 ms so that a
// stop request is seen within 50 ms even with long periods. False when stopped.
bool sleep_until(std::int64_t deadline_ns, const std::atomic<bool>& stop) {
  constexpr std::int64_t kSlice_ns = 50'000'000;
  while (!stop.load(std::memory_order_relaxed)) {
    const std::int64_t now = monotonic_ns();
    if (now >= deadline_ns) return true;
    const std::int64_t target = deadline_ns - now > kSlice_ns ? now + kSlice_ns : deadline_ns;
    timespec ts{static_cast<time_t>(target / 1'000'000'000), static_cast<long>(target % 1'000'000'000)};
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
    }
  }
  return false;
}

// start()/stop() shared by the thread-owning activities.
template <class Body>
void start_thread(std::mutex& mu, std::thread& thread, std::atomic<bool>& stop_requested,
                  std::atomic<bool>& running, Body body) {
  std::lock_guard lock(mu);
  if (running.load() && !stop_requested.load()) return;
  if (thread.joinable()) {
    if (thread.get_id() == std::this_thread::get_id())
      throw std::logic_error("rtm: an activity cannot restart itself from its own cycle");
    thread.join();
  }
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
    : cycle_(std::move(cycle)), options_(std::move(options)) {
  if (!cycle_) throw std::invalid_argument("PeriodicActivity: empty cycle function");
  if (options_.period_ns <= 0)
    throw std::invalid_argument("PeriodicActivity: period_ns must be > 0, got " + std::to_string(options_.period_ns));
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
  start_thread(control_mu_, thread_, stop_requested_, running_, [this] { loop(); });
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

bool PeriodicActivity::running() const { return running_.load(); }

ActivityStats PeriodicActivity::stats() const {
  ActivityStats s;
  s.period_ns = options_.period_ns;
  s.cycles = cycles_.load(std::memory_order_relaxed);
  s.overruns = overruns_.load(std::memory_order_relaxed);
  s.skipped = skipped_.load(std::memory_order_relaxed);
  s.lateness_p50_ns = lateness_.percentile_ns(0.50);
  s.lateness_p99_ns = lateness_.percentile_ns(0.99);
  s.lateness_max_ns = lateness_.max_ns();
  const std::uint64_t samples = period_samples_.load(std::memory_order_relaxed);
  s.mean_period_error_ns =
      samples ? static_cast<double>(period_error_sum_ns_.load(std::memory_order_relaxed)) / static_cast<double>(samples)
              : 0.0;
  return s;
}

void PeriodicActivity::loop() {
  own_thread_id_.store(std::this_thread::get_id());
  apply_periodic_settings(options_);
  const std::int64_t period = options_.period_ns;
  std::int64_t deadline = first_deadline(options_.first_deadline_ns, period, monotonic_ns());
  std::int64_t previous_wake = -1;
  std::uint64_t previous_skipped = 0;
  std::uint64_t cycle = 0;
  while (sleep_until(deadline, stop_requested_)) {
    const std::int64_t wake = monotonic_ns();
    const std::int64_t lateness = wake - deadline;
    lateness_.record(lateness);
    if (previous_wake >= 0) {
      const auto nominal = static_cast<std::int64_t>(previous_skipped + 1) * period;
      period_error_sum_ns_.fetch_add(wake - previous_wake - nominal, std::memory_order_relaxed);
      period_samples_.fetch_add(1, std::memory_order_relaxed);
    }
    previous_wake = wake;
    const CycleContext ctx{cycle++, deadline, wake, period};
    const bool keep_running = cycle_(ctx);
    cycles_.fetch_add(1, std::memory_order_relaxed);
    if (!keep_running) break;
    const ScheduleStep step = next_deadline(deadline, period, monotonic_ns());
    if (step.overrun || lateness > period) overruns_.fetch_add(1, std::memory_order_relaxed);
    skipped_.fetch_add(step.skipped, std::memory_order_relaxed);
    previous_skipped = step.skipped;
    deadline = step.next_deadline_ns;
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
  start_thread(control_mu_, thread_, stop_requested_, running_, [this] { loop(); });
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

void OnArrivalActivity::loop() {
  own_thread_id_.store(std::this_thread::get_id());
  set_thread_name(thread_name_);
  std::uint64_t seen = signal_->count();
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
