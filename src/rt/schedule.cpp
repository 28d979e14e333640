// SPDX-License-Identifier: Apache-2.0
#include "rt/schedule.h"

#include <charconv>
#include <cmath>
#include <stdexcept>
#include <string>

namespace rtm {

// ============================ schedule arithmetic =====================

ScheduleStep next_deadline(std::int64_t deadline_ns, std::int64_t period_ns, std::int64_t now_ns,
                           std::int64_t catch_up_ns) {
  if (catch_up_ns <= 0) catch_up_ns = period_ns;
  const std::int64_t next = deadline_ns + period_ns;
  if (now_ns - next < catch_up_ns) return {next, 0, false};
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

std::optional<double> parse_duration_ns(std::string_view text) {
  struct Unit {
    std::string_view suffix;
    double ns;
  };
  // Longest suffixes first: "ms" and "ns" also end in "s".
  static constexpr Unit kUnits[] = {{"ms", 1e6}, {"us", 1e3}, {"ns", 1.0}, {"s", 1e9}};
  std::string_view number = text;
  double scale = 1e9;
  for (const auto& unit : kUnits) {
    if (text.size() > unit.suffix.size() && text.ends_with(unit.suffix)) {
      number = text.substr(0, text.size() - unit.suffix.size());
      scale = unit.ns;
      break;
    }
  }
  double value = 0;
  const auto [end, ec] = std::from_chars(number.data(), number.data() + number.size(), value);
  const double ns = value * scale;
  if (ec != std::errc{} || end != number.data() + number.size() || !std::isfinite(ns)) return std::nullopt;
  return ns;
}

// ============================ PeriodicSchedule ========================

PeriodicSchedule::PeriodicSchedule(std::int64_t period_ns, std::int64_t catch_up_ns)
    : period_ns_(period_ns), catch_up_ns_(catch_up_ns) {
  if (period_ns <= 0)
    throw std::invalid_argument("PeriodicSchedule: period_ns must be > 0, got " + std::to_string(period_ns));
  if (catch_up_ns < 0)
    throw std::invalid_argument("PeriodicSchedule: catch_up_ns must be >= 0 (0: one period), got " +
                                std::to_string(catch_up_ns));
}

void PeriodicSchedule::start(std::int64_t requested_first_ns, std::int64_t now_ns) {
  deadline_ns_.store(first_deadline(requested_first_ns, period_ns_, now_ns), std::memory_order_relaxed);
  previous_wake_ns_ = -1;
  previous_skipped_ = 0;
  cycle_ = 0;
}

CycleContext PeriodicSchedule::begin(std::int64_t wake_ns) {
  const std::int64_t deadline = deadline_ns();
  lateness_ns_ = wake_ns - deadline;
  lateness_.record(lateness_ns_);
  if (previous_wake_ns_ >= 0) {
    const auto nominal = static_cast<std::int64_t>(previous_skipped_ + 1) * period_ns_;
    period_error_sum_ns_.fetch_add(wake_ns - previous_wake_ns_ - nominal, std::memory_order_relaxed);
    period_samples_.fetch_add(1, std::memory_order_relaxed);
  }
  previous_wake_ns_ = wake_ns;
  return CycleContext{cycle_++, deadline, wake_ns, period_ns_};
}

void PeriodicSchedule::end(std::int64_t now_ns) {
  cycles_.fetch_add(1, std::memory_order_relaxed);
  const ScheduleStep step = next_deadline(deadline_ns(), period_ns_, now_ns, catch_up_ns_);
  if (step.overrun || lateness_ns_ > period_ns_) overruns_.fetch_add(1, std::memory_order_relaxed);
  skipped_.fetch_add(step.skipped, std::memory_order_relaxed);
  previous_skipped_ = step.skipped;
  deadline_ns_.store(step.next_deadline_ns, std::memory_order_relaxed);
}

ActivityStats PeriodicSchedule::stats() const {
  ActivityStats s;
  s.period_ns = period_ns_;
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

}  // namespace rtm
