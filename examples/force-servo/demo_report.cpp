// SPDX-License-Identifier: Apache-2.0
#include "demo_report.h"

#include "report_text.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <map>
#include <charconv>
#include <cmath>
#include <fstream>
#include <numeric>
#include <sstream>

namespace rtm::demo {

namespace {

using Vec3 = std::array<double, 3>;

double norm(const Vec3& v) { return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

Vec3 minus(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }

double max_abs_difference(const Vec3& a, const Vec3& b) {
  return std::max({std::abs(a[0] - b[0]), std::abs(a[1] - b[1]), std::abs(a[2] - b[2])});
}

double error_N(const Sample& s) { return norm(minus(s.reference_N, s.measured_N)); }

// Splits one CSV line on commas (no quoting in what rtm watch writes).
std::vector<std::string_view> split_fields(std::string_view line) {
  std::vector<std::string_view> fields;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    fields.push_back(line.substr(start, comma == std::string_view::npos ? line.npos : comma - start));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return fields;
}

using text::parse_number;
using text::read_file;

// Stable sort by stamp: rtm watch writes in arrival order, which a reordering network path
// could permute.
Series sorted_by_time(const Series& series) {
  std::vector<std::size_t> order(series.time_ns.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return series.time_ns[a] < series.time_ns[b];
  });
  Series sorted;
  sorted.time_ns.reserve(order.size());
  sorted.values.reserve(order.size());
  for (std::size_t i : order) {
    sorted.time_ns.push_back(series.time_ns[i]);
    sorted.values.push_back(series.values[i]);
  }
  return sorted;
}

std::string vec_text(const Vec3& v) { return fmt::format("{:6.1f} {:6.1f} {:6.1f}", v[0], v[1], v[2]); }

}  // namespace

// ============================ recorded streams ========================

Series parse_watch_csv(const std::string& text, const std::string& source_name) {
  Series series;
  std::size_t line_start = 0;
  int line_number = 0;
  bool header_seen = false;
  while (line_start < text.size()) {
    std::size_t line_end = text.find('\n', line_start);
    const bool terminated = line_end != std::string::npos;
    if (!terminated) line_end = text.size();
    const std::string_view line(text.data() + line_start, line_end - line_start);
    line_start = line_end + 1;
    ++line_number;
    if (line.empty() || line == "\r") continue;
    if (!header_seen) {
      if (line.rfind("time_ns", 0) != 0) {
        throw ReportError(fmt::format("{}:{}: expected the header 'time_ns,...' of rtm watch --csv",
                                      source_name, line_number));
      }
      header_seen = true;
      continue;
    }
    const auto fields = split_fields(line);
    std::int64_t stamp_ns = 0;
    std::array<double, 6> values{};
    bool ok = fields.size() >= 7 && parse_number(fields[0], stamp_ns);
    for (std::size_t i = 0; ok && i < 6; ++i) ok = parse_number(fields[i + 1], values[i]);
    if (!ok) {
      // A writer killed mid-line leaves one partial last line: not an error.
      if (!terminated) break;
      throw ReportError(fmt::format("{}:{}: expected time_ns and 6 numbers, got '{}'", source_name,
                                    line_number, line));
    }
    series.time_ns.push_back(stamp_ns);
    series.values.push_back(values);
  }
  if (!header_seen) throw ReportError(fmt::format("{}: empty (no header)", source_name));
  return series;
}

Series read_watch_csv(const std::filesystem::path& path) {
  return parse_watch_csv(read_file(path), path.string());
}

// ============================ aligned samples =========================

std::vector<Sample> align(const Series& reference_in, const Series& sensor_in, const Series& command_in) {
  if (reference_in.time_ns.empty()) throw ReportError("the reference (joystick) stream is empty");
  if (sensor_in.time_ns.empty()) throw ReportError("the sensor stream is empty");
  if (command_in.time_ns.empty()) throw ReportError("the command (controller) stream is empty");
  const Series reference = sorted_by_time(reference_in);
  const Series sensor = sorted_by_time(sensor_in);
  const Series command = sorted_by_time(command_in);
  const auto overlaps = [](const Series& a, const Series& b) {
    return a.time_ns.front() <= b.time_ns.back() && b.time_ns.front() <= a.time_ns.back();
  };
  if (!overlaps(reference, sensor) || !overlaps(command, sensor)) {
    throw ReportError(fmt::format(
        "the streams do not overlap in time (reference {}..{} ns, sensor {}..{} ns, command "
        "{}..{} ns): stamped on different clocks?",
        reference.time_ns.front(), reference.time_ns.back(), sensor.time_ns.front(),
        sensor.time_ns.back(), command.time_ns.front(), command.time_ns.back()));
  }

  std::vector<Sample> samples;
  samples.reserve(sensor.time_ns.size());
  std::size_t ref_next = 0, cmd_next = 0;  // first index stamped after the current sensor stamp
  std::int64_t origin_ns = 0;
  for (std::size_t i = 0; i < sensor.time_ns.size(); ++i) {
    const std::int64_t t_ns = sensor.time_ns[i];
    while (ref_next < reference.time_ns.size() && reference.time_ns[ref_next] <= t_ns) ++ref_next;
    while (cmd_next < command.time_ns.size() && command.time_ns[cmd_next] <= t_ns) ++cmd_next;
    if (ref_next == 0) continue;
    if (samples.empty()) origin_ns = t_ns;
    Sample s;
    s.time_s = static_cast<double>(t_ns - origin_ns) * 1e-9;
    const auto& ref = reference.values[ref_next - 1];
    const auto& sen = sensor.values[i];
    for (int k = 0; k < 3; ++k) {
      s.reference_N[k] = ref[k];
      s.measured_N[k] = -sen[k];
    }
    if (cmd_next > 0) s.velocity = command.values[cmd_next - 1];
    samples.push_back(s);
  }
  return samples;
}

// ============================ phases ==================================

std::vector<Phase> detect_phases(const std::vector<Sample>& samples, const PhaseOptions& options) {
  std::vector<Phase> phases;
  std::size_t start = 0;
  while (start < samples.size()) {
    std::size_t end = start + 1;
    while (end < samples.size() &&
           max_abs_difference(samples[end].reference_N, samples[start].reference_N) <=
               options.reference_tolerance_N) {
      ++end;
    }
    if (samples[end - 1].time_s - samples[start].time_s >= options.min_duration_s) {
      phases.push_back({start, end});
      start = end;
    } else {
      ++start;  // inside a ramp: try the next sample as a phase start
    }
  }
  return phases;
}

PhaseSummary summarize(const std::vector<Sample>& samples, const Phase& phase,
                       const PhaseOptions& options) {
  if (phase.begin >= phase.end || phase.end > samples.size()) {
    throw std::invalid_argument(fmt::format("phase [{}, {}) outside the {} samples", phase.begin,
                                            phase.end, samples.size()));
  }
  PhaseSummary summary;
  summary.start_s = samples[phase.begin].time_s;
  summary.end_s = samples[phase.end - 1].time_s;
  summary.reference_N = samples[phase.begin].reference_N;

  // The force error is taken along the reference: pressing "at 10 N" is about the normal
  // force; friction on the table shows as a lateral force, reported apart. Without a
  // reference direction (hands off) it is the whole vector.
  const double reference_norm_N = norm(summary.reference_N);
  const bool has_axis = reference_norm_N > options.contact_threshold_N;
  Vec3 axis{};
  if (has_axis) {
    for (int k = 0; k < 3; ++k) axis[k] = summary.reference_N[k] / reference_norm_N;
  }
  const auto phase_error_N = [&](const Vec3& reference, const Vec3& measured) {
    const Vec3 e = minus(reference, measured);
    return has_axis ? std::abs(e[0] * axis[0] + e[1] * axis[1] + e[2] * axis[2]) : norm(e);
  };

  // Steady state: the last steady_window_s, but never more than the phase's second half.
  const double window_start_s = std::max(summary.end_s - options.steady_window_s,
                                         (summary.start_s + summary.end_s) / 2);
  Vec3 measured_sum{}, velocity_sum{};
  double error_min = INFINITY, error_max = 0;
  std::size_t count = 0;
  for (std::size_t i = phase.begin; i < phase.end; ++i) {
    const Sample& s = samples[i];
    if (s.time_s < window_start_s) continue;
    for (int k = 0; k < 3; ++k) {
      measured_sum[k] += s.measured_N[k];
      velocity_sum[k] += s.velocity[k];
    }
    const double e = phase_error_N(s.reference_N, s.measured_N);
    error_min = std::min(error_min, e);
    error_max = std::max(error_max, e);
    ++count;
  }
  for (int k = 0; k < 3; ++k) {
    summary.mean_measured_N[k] = measured_sum[k] / static_cast<double>(count);
    summary.mean_velocity_m_s[k] = velocity_sum[k] / static_cast<double>(count);
  }
  summary.steady_error_N = phase_error_N(summary.reference_N, summary.mean_measured_N);
  if (has_axis) {
    const Vec3& m = summary.mean_measured_N;
    const double along_N = m[0] * axis[0] + m[1] * axis[1] + m[2] * axis[2];
    summary.lateral_N = norm(minus(m, {along_N * axis[0], along_N * axis[1], along_N * axis[2]}));
  }
  summary.error_peak_to_peak_N = error_max - error_min;
  summary.contact = norm(summary.mean_measured_N) > options.contact_threshold_N;

  // Settled at the first sample after the last one outside the band.
  std::size_t first_settled = phase.begin;
  for (std::size_t i = phase.end; i-- > phase.begin;) {
    if (phase_error_N(samples[i].reference_N, samples[i].measured_N) > options.settle_band_N) {
      first_settled = i + 1;
      break;
    }
  }
  if (first_settled < phase.end && summary.end_s - samples[first_settled].time_s >= options.min_settled_s) {
    summary.settling_time_s = samples[first_settled].time_s - summary.start_s;
  }
  return summary;
}

// ============================ demo figures ============================

namespace {

double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

bool finite(const Vec3& v) { return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]); }

void check_figure_inputs(const std::vector<Sample>& samples, const std::vector<Phase>& phases,
                         const PhaseOptions& options, const FigureLimits& limits) {
  const auto positive = [](double v) { return std::isfinite(v) && v > 0; };
  const auto non_negative = [](double v) { return std::isfinite(v) && v >= 0; };
  if (!positive(options.settle_band_N))
    throw std::invalid_argument(fmt::format("settling band {} N: must be positive", options.settle_band_N));
  if (!positive(options.contact_threshold_N))
    throw std::invalid_argument(fmt::format("contact threshold {} N: must be positive", options.contact_threshold_N));
  if (!non_negative(options.min_settled_s))
    throw std::invalid_argument(fmt::format("minimum settled time {} s: must not be negative", options.min_settled_s));
  if (!positive(limits.release_level_N))
    throw std::invalid_argument(fmt::format("release level {} N: must be positive", limits.release_level_N));
  if (samples.empty()) throw ReportError("no samples to compute the demo figures on");
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const Sample& s = samples[i];
    if (!std::isfinite(s.time_s) || !finite(s.reference_N) || !finite(s.measured_N)) {
      throw ReportError(fmt::format("sample {} (at {:.4f} s): a non-finite time, reference or force", i, s.time_s));
    }
  }
  std::size_t previous_end = 0;
  for (std::size_t k = 0; k < phases.size(); ++k) {
    const Phase& p = phases[k];
    if (p.begin >= p.end || p.end > samples.size() || p.begin < previous_end) {
      throw std::invalid_argument(fmt::format("phase {} [{}, {}): empty, outside the {} samples or out of order",
                                              k + 1, p.begin, p.end, samples.size()));
    }
    previous_end = p.end;
  }
}

// Figures 1 and 2: each touch-down, its overshoot and settling (see TouchDown).
std::vector<TouchDown> find_touch_downs(const std::vector<Sample>& samples, const std::vector<Phase>& phases,
                                        const PhaseOptions& options) {
  const double threshold_N = options.contact_threshold_N;
  const double band_N = options.settle_band_N;
  const auto presses = [&](const Sample& s) { return norm(s.reference_N) > threshold_N; };
  // The force along the sample's own reference (only where it presses).
  const auto along = [](const Sample& s) { return dot(s.measured_N, s.reference_N) / norm(s.reference_N); };

  // The end of a touch-down window's limit: the end of the phase holding sample i, or of the
  // next phase when i is in a ramp; the recording's end when no phase follows.
  const auto window_limit = [&](std::size_t i) {
    for (const Phase& p : phases)
      if (p.end > i) return p.end;
    return samples.size();
  };

  std::vector<TouchDown> touch_downs;
  // 1, 2: touch-downs, their overshoot and settling.
  bool armed = false;  // the force has been below the threshold since the last touch-down
  std::size_t i = 0;
  while (i < samples.size()) {
    const Sample& s = samples[i];
    const bool pressing = presses(s);
    const double force_N = pressing ? along(s) : norm(s.measured_N);
    if (!pressing || !armed || force_N < threshold_N) {
      if (force_N < threshold_N) armed = true;
      ++i;
      continue;
    }
    armed = false;
    TouchDown touch;
    touch.time_s = s.time_s;
    touch.reference_N = s.reference_N;
    // The window's candidates: up to the limit, while the reference presses.
    const std::size_t limit = window_limit(i);
    std::size_t end = i;
    while (end < limit && presses(samples[end])) ++end;
    const auto in_band = [&](const Sample& w) { return std::abs(norm(w.reference_N) - along(w)) <= band_N; };
    std::size_t settled = i;  // the first sample after the last one outside the band
    for (std::size_t k = end; k-- > i;) {
      if (!in_band(samples[k])) {
        settled = k + 1;
        break;
      }
    }
    const bool has_settled = settled < end && samples[end - 1].time_s - samples[settled].time_s >= options.min_settled_s;
    if (has_settled) end = settled + 1;  // the transient ends where the force has settled
    std::size_t peak = i;
    for (std::size_t k = i; k < end; ++k)
      if (along(samples[k]) > along(samples[peak])) peak = k;
    if (has_settled) touch.settling_time_s = samples[settled].time_s - touch.time_s;
    touch.peak_N = along(samples[peak]);
    touch.peak_time_s = samples[peak].time_s;
    touch.peak_reference_N = norm(samples[peak].reference_N);
    touch.overshoot = touch.peak_N / touch.peak_reference_N - 1;
    touch.window_end_s = samples[end - 1].time_s;
    touch_downs.push_back(touch);
    i = end;
  }

  return touch_downs;
}

}  // namespace

DemoFigures compute_figures(const std::vector<Sample>& samples, const std::vector<Phase>& phases,
                            const PhaseOptions& options, const FigureLimits& limits) {
  check_figure_inputs(samples, phases, options, limits);
  const double threshold_N = options.contact_threshold_N;
  std::vector<PhaseSummary> summaries;
  summaries.reserve(phases.size());
  for (const Phase& p : phases) summaries.push_back(summarize(samples, p, options));

  DemoFigures figures;

  figures.touch_downs = find_touch_downs(samples, phases, options);

  // 3: reference steps while in contact; 4: the release after the last press.
  const auto press_axis = [&](const PhaseSummary& p) -> std::optional<Vec3> {
    const double r_N = norm(p.reference_N);
    if (r_N <= threshold_N || !p.contact) return std::nullopt;
    const Vec3 u{p.reference_N[0] / r_N, p.reference_N[1] / r_N, p.reference_N[2] / r_N};
    if (dot(p.mean_measured_N, u) <= threshold_N) return std::nullopt;
    return u;
  };
  std::optional<std::size_t> last_press;
  for (std::size_t k = 0; k < phases.size(); ++k) {
    const auto u = press_axis(summaries[k]);
    if (!u) continue;
    last_press = k;
    const Phase& p = phases[k];
    if (p.begin == 0 || dot(samples[p.begin].measured_N, *u) < threshold_N) continue;
    StepInContact step;
    step.phase = k;
    step.start_s = summaries[k].start_s;
    step.from_N = dot(k > 0 ? summaries[k - 1].reference_N : samples[p.begin - 1].reference_N, *u);
    step.to_N = norm(summaries[k].reference_N);
    step.settling_time_s = summaries[k].settling_time_s;
    figures.steps.push_back(step);
  }
  if (last_press) {
    const Phase& p = phases[*last_press];
    Release release;
    release.phase = *last_press;
    release.axis = *press_axis(summaries[*last_press]);
    release.start_s = samples[p.end - 1].time_s;
    release.end_s = samples.back().time_s;
    const auto above = [&](const Sample& s) { return std::abs(dot(s.measured_N, release.axis)) >= limits.release_level_N; };
    for (std::size_t k = p.end; k < samples.size(); ++k) {
      if (above(samples[k]) != above(samples[k - 1])) ++release.transitions;
    }
    release.lifted = !above(samples.back());
    figures.release = release;
  }
  return figures;
}

// ============================ loop timing =============================

std::vector<ComponentTiming> parse_timing_json(const std::string& text, const std::string& source_name) {
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    throw ReportError(fmt::format("{}: not JSON: {}", source_name, e.what()));
  }
  if (!doc.is_array()) throw ReportError(fmt::format("{}: expected the array `rtm --json ls -l` prints", source_name));
  std::vector<ComponentTiming> result;
  try {
    for (const auto& c : doc) {
      ComponentTiming t;
      t.name = c.at("name").get<std::string>();
      if (!c.value("alive", true)) {
        t.state = "dead";
        result.push_back(t);
        continue;
      }
      t.kind = c.value("kind", "");
      t.state = c.value("state", "");
      t.period_ns = c.value("period_ns", std::int64_t{0});
      t.last_error = c.value("last_error", "");
      if (c.contains("timing")) {
        const auto& timing = c.at("timing");
        t.cycles = timing.at("cycles").get<std::uint64_t>();
        t.overruns = timing.at("overruns").get<std::uint64_t>();
        t.lateness_p99_ns = timing.at("lateness_p99_ns").get<std::int64_t>();
        t.lateness_max_ns = timing.at("lateness_max_ns").get<std::int64_t>();
      }
      if (c.contains("contract") && c.at("contract").value("watched", false)) {
        const auto& k = c.at("contract");
        t.contract = ComponentTiming::Contract{k.at("deadline_ns").get<std::int64_t>(),
                                               k.at("budget_ns").get<std::int64_t>(),
                                               k.at("missed_deadline").get<std::uint64_t>(),
                                               k.at("over_budget").get<std::uint64_t>(),
                                               k.at("response_ns").at("p99").get<std::int64_t>(),
                                               k.at("response_ns").at("max").get<std::int64_t>(),
                                               k.at("cycle_ns").at("p99").get<std::int64_t>(),
                                               k.at("cycle_ns").at("max").get<std::int64_t>()};
      }
      if (c.contains("statistics")) {
        for (const auto& [name, s] : c.at("statistics").items())
          t.statistics.push_back({name, s.at("value").get<double>(), s.value("unit", "")});
      }
      result.push_back(t);
    }
  } catch (const nlohmann::json::exception& e) {
    throw ReportError(fmt::format("{}: unexpected component entry: {}", source_name, e.what()));
  }
  return result;
}

std::optional<FoundStatistic> find_statistic(const std::vector<ComponentTiming>& timing, std::string_view name) {
  for (const auto& t : timing) {
    for (const auto& s : t.statistics)
      if (s.name == name) return FoundStatistic{t.name, s};
  }
  return std::nullopt;
}

// ============================ output ==================================

namespace {

std::string statistic_text(const NamedStatistic& s) {
  const std::string value = s.value == std::floor(s.value) ? fmt::format("{:.0f}", s.value) : fmt::format("{:.1f}", s.value);
  return s.unit.empty() ? value : value + " " + s.unit;
}

// The figures the demo promises, read from the components' own statistics.
std::string format_figures(const std::vector<ComponentTiming>& timing) {
  std::string out;
  const auto p50 = find_statistic(timing, "latency_p50");
  const auto p99 = find_statistic(timing, "latency_p99");
  const auto max = find_statistic(timing, "latency_max");
  if (p50 && p99 && max) {
    out += fmt::format("Sensor sample to drive command leaving for the bus ({}): p50 {}, p99 {}, max {}\n", p50->component,
                       statistic_text(p50->statistic), statistic_text(p99->statistic), statistic_text(max->statistic));
  }
  if (const auto r = find_statistic(timing, "command_loss_recoveries"))
    out += fmt::format("Drive command-loss recoveries ({}): {}\n", r->component, statistic_text(r->statistic));
  // Stalls survived: the master took the bus cycles back from a late shared tick, or drives
  // fell silent for a few SYNCs with their heartbeat on. Shown only when they happened.
  for (const auto& [name, text] : {std::pair{"cycle_owner_recoveries", "Bus cycles taken back from a late tick"},
                                   std::pair{"feedback_gap_recoveries", "Drive feedback-gap recoveries"}}) {
    const auto r = find_statistic(timing, name);
    if (r && r->statistic.value > 0)
      out += fmt::format("{} ({}): {}\n", text, r->component, statistic_text(r->statistic));
  }
  const auto w = find_statistic(timing, "watchdog_events");
  out += fmt::format("Watchdog events ({}): {}\n", w ? w->component : "actuator",
                     w ? statistic_text(w->statistic) : std::string("unknown"));
  return out;
}

std::string percent(double fraction) { return fmt::format("{:.1f} %", fraction * 100); }

}  // namespace

namespace {

// Figures 1-4: the touch-downs, the steps in contact and the release.
void evaluate_operator_figures(const Report& report, const PhaseOptions& options, const FigureLimits& limits,
                               std::vector<FigureVerdict>& verdicts) {
  const DemoFigures& f = report.figures;
  const std::string band = fmt::format("+-{:g} N", options.settle_band_N);

  const std::string overshoot_limit = fmt::format("<= {:g} %", limits.max_overshoot * 100);
  const std::string touch_settle_limit = fmt::format("<= {:.2f} s", limits.max_touch_down_settling_s);
  if (f.touch_downs.empty()) {
    const std::string why = fmt::format("not measured: no touch-down (force along a pressing reference rising through {:g} N)",
                                        options.contact_threshold_N);
    verdicts.push_back({"touch-down overshoot", why, overshoot_limit, false});
    verdicts.push_back({"settling after touch-down", why, touch_settle_limit, false});
  }
  for (const auto& t : f.touch_downs) {
    verdicts.push_back({"touch-down overshoot",
                        fmt::format("{} (touch-down at {:.2f} s: peak {:.2f} N at {:.2f} s on {:.1f} N)", percent(t.overshoot),
                                    t.time_s, t.peak_N, t.peak_time_s, t.peak_reference_N),
                        overshoot_limit, t.overshoot <= limits.max_overshoot});
    verdicts.push_back({"settling after touch-down",
                        t.settling_time_s ? fmt::format("{:.2f} s to {} (touch-down at {:.2f} s)", *t.settling_time_s, band, t.time_s)
                                          : fmt::format("not settled to {} by {:.2f} s (touch-down at {:.2f} s)", band,
                                                        t.window_end_s, t.time_s),
                        touch_settle_limit,
                        t.settling_time_s && *t.settling_time_s <= limits.max_touch_down_settling_s});
  }

  const std::string step_limit = fmt::format("<= {:.2f} s", limits.max_step_settling_s);
  if (f.steps.empty()) {
    verdicts.push_back({"settling after a step in contact", "not measured: no reference step while touching", step_limit, false});
  }
  for (const auto& s : f.steps) {
    const std::string step = fmt::format("{:.1f} -> {:.1f} N, phase {} from {:.2f} s", s.from_N, s.to_N, s.phase + 1, s.start_s);
    verdicts.push_back({"settling after a step in contact",
                        s.settling_time_s ? fmt::format("{:.2f} s to {} ({})", *s.settling_time_s, band, step)
                                          : fmt::format("not settled to {} ({})", band, step),
                        step_limit, s.settling_time_s && *s.settling_time_s <= limits.max_step_settling_s});
  }

  const std::string release_limit = fmt::format("<= {}", limits.max_release_transitions);
  if (!f.release) {
    verdicts.push_back({"touch/lift transitions at release", "not measured: no press phase", release_limit, false});
  } else {
    const Release& r = *f.release;
    verdicts.push_back({"touch/lift transitions at release",
                        fmt::format("{} (|force| through {:g} N, {:.2f} - {:.2f} s{})", r.transitions,
                                    limits.release_level_N, r.start_s, r.end_s,
                                    r.lifted ? "" : "; still in contact at the end"),
                        release_limit, r.lifted && r.transitions <= limits.max_release_transitions});
  }
}

}  // namespace

std::vector<FigureVerdict> evaluate_figures(const Report& report, const PhaseOptions& options,
                                            const FigureLimits& limits) {
  std::vector<FigureVerdict> verdicts;
  if (report.operator_figures) evaluate_operator_figures(report, options, limits, verdicts);
  const std::string watchdog_limit = fmt::format("<= {:g}", limits.max_watchdog_events);
  if (const auto w = find_statistic(report.timing, "watchdog_events")) {
    const double explained = limits.explained_watchdog_events;
    if (explained < 0) {
      verdicts.push_back({"watchdog events", fmt::format("{} ({})", statistic_text(w->statistic), w->component),
                          watchdog_limit, w->statistic.value <= limits.max_watchdog_events});
    } else {
      const double unexplained = std::max(0.0, w->statistic.value - explained);
      verdicts.push_back({"watchdog events",
                          fmt::format("{:g} not explained by a host stall, of {} ({})", unexplained,
                                      statistic_text(w->statistic), w->component),
                          watchdog_limit, unexplained <= limits.max_watchdog_events});
    }
  } else {
    verdicts.push_back({"watchdog events", "not measured: no component reports watchdog_events", watchdog_limit, false});
  }
  return verdicts;
}

std::vector<std::string> missed_figures(const Report& report, const PhaseOptions& options,
                                        const FigureLimits& limits) {
  std::vector<std::string> missed;
  for (std::size_t i = 0; report.operator_figures && i < report.phases.size(); ++i) {
    const auto& p = report.phases[i];
    if (!p.contact) continue;
    if (p.steady_error_N > options.settle_band_N) {
      missed.push_back(fmt::format("phase {}: steady-state error {:.2f} N > {:g} N", i + 1, p.steady_error_N,
                                   options.settle_band_N));
    }
  }
  for (const auto& t : report.timing) {
    if (t.overruns > 0) missed.push_back(fmt::format("{}: {} overruns", t.name, t.overruns));
  }
  for (const auto& v : evaluate_figures(report, options, limits)) {
    if (!v.ok) missed.push_back(fmt::format("{}: {} (limit {})", v.figure, v.value, v.limit));
  }
  return missed;
}

namespace {

// Each watched component's contract as it kept it over the run (rtm ls -l's "contract").
std::string format_contracts(const std::vector<ComponentTiming>& timing) {
  std::string out = "\nTiming contracts (docs/timing.md; response: release to the cycle's end; cycle: its start to its end)\n";
  bool any_contract = false;
  for (const auto& t : timing) {
    if (!t.contract) continue;
    any_contract = true;
    const auto& k = *t.contract;
    const std::string deadline = k.missed_deadline == 0 ? "met" : fmt::format("MISSED {}x", k.missed_deadline);
    const std::string budget = k.budget_ns == 0 ? std::string("none declared")
                               : k.over_budget == 0 ? fmt::format("{:g} us met", k.budget_ns / 1e3)
                                                    : fmt::format("{:g} us EXCEEDED {}x", k.budget_ns / 1e3, k.over_budget);
    out += fmt::format("  {:<14} deadline {:g} us {} (response p99 {:.1f} us, max {:.1f} us); budget {} (cycle p99 {:.1f} us, max {:.1f} us)\n",
                       t.name, k.deadline_ns / 1e3, deadline, k.response_p99_ns / 1e3, k.response_max_ns / 1e3, budget,
                       k.cycle_p99_ns / 1e3, k.cycle_max_ns / 1e3);
  }
  if (!any_contract) out += "  (no component watched)\n";
  // Each chain as its end measured it while running (statistics chain.<name>.*).
  for (const auto& t : timing) {
    std::map<std::string, std::map<std::string, double>> chains;  // chain -> figure -> value
    for (const auto& s : t.statistics) {
      if (!s.name.starts_with("chain.")) continue;
      const std::size_t dot = s.name.find('.', 6);
      if (dot == std::string::npos) continue;
      chains[s.name.substr(6, dot - 6)][s.name.substr(dot + 1)] = s.value;
    }
    for (const auto& [name, f] : chains) {
      const auto v = [&f](const char* key) { return f.contains(key) ? f.at(key) : 0.0; };
      out += fmt::format("  chain {} at {}: latency p50 {:g} us, p99 {:g} us, max {:g} us; age p99 {:g} us, max {:g} us; "
                         "late {:g}, stale {:g}\n",
                         name, t.name, v("latency_p50"), v("latency_p99"), v("latency_max"), v("age_p99"), v("age_max"),
                         v("late"), v("stale"));
    }
  }
  return out;
}

}  // namespace

std::string format_report(const Report& report, const PhaseOptions& options, const FigureLimits& limits) {
  std::string out = fmt::format("Force servo: {} samples over {:.1f} s\n\n", report.samples, report.duration_s);
  out += fmt::format(
      "Phases (measured = force the hand applies; error = along the reference, over the "
      "steady state = the phase's last {:g} s; settled = |error| within {:g} N to the phase end; "
      "lateral = measured force across the reference)\n",
      options.steady_window_s, options.settle_band_N);
  out += fmt::format("  {:>3} {:>13}  {:<20}  {:<20}  {:>8}  {:>8}  {:>8}  {:>8}  {}\n", "#", "time [s]",
                     "reference [N] x y z", "measured [N] x y z", "error[N]", "p-p [N]",
                     "lateral", "settle", "");
  int index = 1;
  for (const auto& p : report.phases) {
    // Settling is a contact notion: in free space the force error is the push itself.
    const std::string settle = !p.contact           ? std::string(1, '-')
                               : p.settling_time_s ? fmt::format("{:.2f} s", *p.settling_time_s)
                                                   : std::string("never");
    const Vec3 v_mm_s{p.mean_velocity_m_s[0] * 1e3, p.mean_velocity_m_s[1] * 1e3, p.mean_velocity_m_s[2] * 1e3};
    const std::string note = p.contact ? std::string("contact")
                             : norm(p.reference_N) > options.contact_threshold_N
                                 ? fmt::format("free space: moving {} mm/s", vec_text(v_mm_s))
                                 : std::string("free space, hands off");
    const auto number = [&](double v) { return p.contact ? fmt::format("{:.2f}", v) : std::string(1, '-'); };
    out += fmt::format("  {:>3} {:5.1f} - {:5.1f}  {}  {}  {:>8}  {:>8}  {:>8}  {:>8}  {}\n", index++,
                       p.start_s, p.end_s, vec_text(p.reference_N), vec_text(p.mean_measured_N),
                       number(p.steady_error_N), number(p.error_peak_to_peak_N), number(p.lateral_N),
                       settle, note);
  }
  if (report.phases.empty()) out += "  (no phase of constant reference found)\n";

  out += "\nLoop timing per component (rtm ls -l; overruns: cycles more than one period late)\n";
  out += fmt::format("  {:<14} {:<11} {:<6} {:>8} {:>10} {:>12} {:>12} {:>9}\n", "component", "kind",
                     "state", "period", "cycles", "late p99", "late max", "overruns");
  for (const auto& t : report.timing) {
    if (t.cycles == 0) {
      out += fmt::format("  {:<14} {:<11} {:<6} {:>8}\n", t.name, t.kind, t.state,
                         t.period_ns ? fmt::format("{:g} ms", t.period_ns / 1e6) : "-");
      continue;
    }
    out += fmt::format("  {:<14} {:<11} {:<6} {:>8} {:>10} {:>9.1f} us {:>9.1f} us {:>9}\n", t.name,
                       t.kind, t.state, fmt::format("{:g} ms", t.period_ns / 1e6), t.cycles,
                       t.lateness_p99_ns / 1e3, t.lateness_max_ns / 1e3, t.overruns);
  }
  if (report.timing.empty()) out += "  (no timing recorded)\n";
  for (const auto& t : report.timing) {
    if (!t.last_error.empty()) out += fmt::format("  ! {} ({}): {}\n", t.name, t.state, t.last_error);
  }
  out += format_contracts(report.timing);
  out += "\nStatistics the components publish (rtm cat)\n";
  for (const auto& t : report.timing) {
    if (t.statistics.empty()) continue;
    // Four to a line: "  actuator0      clamped 0, commands 14331, ..."
    for (std::size_t i = 0; i < t.statistics.size(); i += 4) {
      std::string line;
      for (std::size_t k = i; k < std::min(i + 4, t.statistics.size()); ++k)
        line += fmt::format("{}{} {}", k == i ? "" : ", ", t.statistics[k].name, statistic_text(t.statistics[k]));
      out += fmt::format("  {:<14} {}\n", i == 0 ? t.name : "", line);
    }
  }
  out += "\n" + format_figures(report.timing);

  out += fmt::format(
      "\nDemo figures (force along the reference; touch-down: rising through {:g} N; settled: "
      "within +-{:g} N from then to the phase end, at least {:g} s)\n",
      options.contact_threshold_N, options.settle_band_N, options.min_settled_s);
  for (const auto& v : evaluate_figures(report, options, limits)) {
    out += fmt::format("  {:<34} {:<10} {:<6} {}\n", v.figure, v.limit, v.ok ? "ok" : "MISSED", v.value);
  }
  return out;
}

void write_samples_csv(const std::filesystem::path& path, const std::vector<Sample>& samples) {
  std::ofstream out(path);
  if (!out) throw ReportError(fmt::format("{}: cannot write", path.string()));
  out << "time_s,ref_x_N,ref_y_N,ref_z_N,measured_x_N,measured_y_N,measured_z_N,error_N,"
         "v_x_m_s,v_y_m_s,v_z_m_s,w_x_rad_s,w_y_rad_s,w_z_rad_s\n";
  for (const auto& s : samples) {
    out << fmt::format("{:.4f},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f}\n",
                       s.time_s, s.reference_N[0], s.reference_N[1], s.reference_N[2], s.measured_N[0],
                       s.measured_N[1], s.measured_N[2], error_N(s), s.velocity[0], s.velocity[1],
                       s.velocity[2], s.velocity[3], s.velocity[4], s.velocity[5]);
  }
  if (!out.flush()) throw ReportError(fmt::format("{}: write failed", path.string()));
}

std::string gnuplot_script(const std::filesystem::path& csv, const std::filesystem::path& png,
                           const std::vector<PhaseSummary>& phases) {
  std::string s;
  s += "set terminal pngcairo size 1200,900 noenhanced\n";
  s += fmt::format("set output '{}'\n", png.string());
  s += "set datafile separator ','\n";
  s += "set key outside right top\n";
  s += "set grid\n";
  for (const auto& p : phases) {
    s += fmt::format("set arrow from {0:.3f}, graph 0 to {0:.3f}, graph 1 nohead lc rgb '#bbbbbb' dt 2\n", p.start_s);
  }
  s += "set multiplot layout 2,1 title 'Force servo on the PA10: reference (operator) vs measured force, and the commanded velocity'\n";
  s += "set ylabel 'force [N]'\n";
  s += fmt::format(
      "plot '{0}' using 1:2 skip 1 with lines lw 2 lc rgb '#1f77b4' dt 2 title 'ref x', \\\n"
      "     '{0}' using 1:5 skip 1 with lines lw 1 lc rgb '#1f77b4' title 'measured x', \\\n"
      "     '{0}' using 1:3 skip 1 with lines lw 2 lc rgb '#2ca02c' dt 2 title 'ref y', \\\n"
      "     '{0}' using 1:6 skip 1 with lines lw 1 lc rgb '#2ca02c' title 'measured y', \\\n"
      "     '{0}' using 1:4 skip 1 with lines lw 2 lc rgb '#d62728' dt 2 title 'ref z', \\\n"
      "     '{0}' using 1:7 skip 1 with lines lw 1 lc rgb '#d62728' title 'measured z'\n",
      csv.string());
  s += "set xlabel 'time [s]'\n";
  s += "set ylabel 'velocity command [mm/s]'\n";
  s += fmt::format(
      "plot '{0}' using 1:($9*1000) skip 1 with lines lc rgb '#1f77b4' title 'v x', \\\n"
      "     '{0}' using 1:($10*1000) skip 1 with lines lc rgb '#2ca02c' title 'v y', \\\n"
      "     '{0}' using 1:($11*1000) skip 1 with lines lc rgb '#d62728' title 'v z'\n",
      csv.string());
  s += "unset multiplot\n";
  return s;
}

// ============================ live display ============================

std::optional<Row> last_complete_row(std::string_view text) {
  // From the last '\n' back: what follows it is a line still being written.
  std::size_t end = text.rfind('\n');
  while (end != std::string_view::npos) {
    const std::size_t previous = end == 0 ? std::string_view::npos : text.rfind('\n', end - 1);
    const std::size_t start = previous == std::string_view::npos ? 0 : previous + 1;
    const auto fields = split_fields(text.substr(start, end - start));
    Row row{};
    bool ok = fields.size() == row.size();
    for (std::size_t i = 0; ok && i < row.size(); ++i) ok = parse_number(fields[i], row[i]);
    if (ok) return row;
    end = previous;
  }
  return std::nullopt;
}

std::optional<Row> last_complete_row_of(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) return std::nullopt;
  const std::streamoff size = in.tellg();
  constexpr std::streamoff kTail = 4096;
  const std::streamoff from = std::max<std::streamoff>(0, size - kTail);
  std::string tail(static_cast<std::size_t>(size - from), '\0');
  in.seekg(from);
  if (!in.read(tail.data(), static_cast<std::streamsize>(tail.size()))) return std::nullopt;
  // A tail that starts mid-file starts mid-line: a mark no number starts with keeps its first
  // line from reading as a row.
  if (from > 0) tail.insert(tail.begin(), 'x');
  return last_complete_row(tail);
}

std::string live_line(int t_s, const Row& r, const Row& s, const Row& c) {
  const double reference_N = std::sqrt(r[1] * r[1] + r[2] * r[2] + r[3] * r[3]);
  std::string phase;
  if (reference_N < 0.5) {
    phase = "hands off";
  } else if (-r[3] > std::sqrt(r[1] * r[1] + r[2] * r[2])) {
    phase = fmt::format("press {:.0f} N", -r[3]);
  } else {
    phase = "free-space push";
  }
  return fmt::format("  {:5d}  {:<16} {:7.1f} {:7.1f} {:7.1f}  {:7.1f} {:7.1f} {:7.1f}  {:7.1f} {:7.1f} {:7.1f}", t_s, phase,
                     r[1], r[2], r[3], -s[1], -s[2], -s[3], 1000 * c[1], 1000 * c[2], 1000 * c[3]);
}

std::string text::read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ReportError(fmt::format("{}: cannot read", path.string()));
  std::ostringstream content;
  content << in.rdbuf();
  return content.str();
}

}  // namespace rtm::demo
