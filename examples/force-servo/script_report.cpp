// SPDX-License-Identifier: Apache-2.0
#include "script_report.h"

#include "report_text.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <string_view>

namespace rtm::demo {
namespace {

constexpr std::string_view kHeader =
    "begin_ns,end_ns,motion,outcome,force_N,normal_x,normal_y,normal_z,along_x,along_y,along_z,description";
constexpr std::size_t kCells = 11;  // before the description

// Three cells: a finite vector, none (all three empty), or false (anything else).
bool parse_vector(const std::vector<std::string_view>& cells, std::size_t first,
                  std::optional<std::array<double, 3>>& out) {
  if (cells[first].empty() && cells[first + 1].empty() && cells[first + 2].empty()) return true;
  std::array<double, 3> v{};
  for (std::size_t i = 0; i < 3; ++i)
    if (!text::parse_number(cells[first + i], v[i]) || !std::isfinite(v[i])) return false;
  out = v;
  return true;
}

double quantile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  const auto k = static_cast<std::size_t>(std::ceil(q * static_cast<double>(values.size()))) - 1;
  const auto at = values.begin() + static_cast<std::ptrdiff_t>(std::min(k, values.size() - 1));
  std::nth_element(values.begin(), at, values.end());
  return *at;
}

double dot(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

std::string vector_text(const std::array<double, 3>& v, double scale) {
  return fmt::format("({:.1f}, {:.1f}, {:.1f})", v[0] * scale, v[1] * scale, v[2] * scale);
}

}  // namespace

std::vector<ScriptPhase> parse_script_phases(const std::string& content, const std::string& source_name) {
  std::vector<ScriptPhase> phases;
  std::size_t start = 0;
  int line_number = 0;
  bool header_seen = false;
  while (start < content.size()) {
    std::size_t end = content.find('\n', start);
    if (end == std::string::npos) end = content.size();
    std::string_view line(content.data() + start, end - start);
    start = end + 1;
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (line.empty()) continue;
    if (!header_seen) {
      if (line != kHeader)
        throw ReportError(fmt::format("{}:{}: expected the header '{}' of a motion script's phase log", source_name,
                                      line_number, kHeader));
      header_seen = true;
      continue;
    }
    std::vector<std::string_view> cells;
    std::size_t from = 0;
    while (cells.size() < kCells) {
      const std::size_t comma = line.find(',', from);
      if (comma == std::string_view::npos) break;
      cells.push_back(line.substr(from, comma - from));
      from = comma + 1;
    }
    const std::string_view rest = cells.size() == kCells ? line.substr(from) : std::string_view{};
    ScriptPhase p;
    double force = 0;
    bool ok = cells.size() == kCells && text::parse_number(cells[0], p.begin_ns) && text::parse_number(cells[1], p.end_ns) &&
              p.end_ns >= p.begin_ns && !cells[2].empty() && !cells[3].empty() && rest.size() >= 2 &&
              rest.front() == '"' && rest.back() == '"';
    if (ok && !cells[4].empty()) {
      ok = text::parse_number(cells[4], force) && std::isfinite(force);
      p.force_N = force;
    }
    ok = ok && parse_vector(cells, 5, p.normal) && parse_vector(cells, 8, p.along);
    if (!ok)
      throw ReportError(fmt::format("{}:{}: expected begin_ns,end_ns (end >= begin),motion,outcome,force_N,3 normal "
                                    "cells,3 along cells,\"description\"; got '{}'",
                                    source_name, line_number, line));
    p.motion = std::string(cells[2]);
    p.outcome = std::string(cells[3]);
    p.description = std::string(rest.substr(1, rest.size() - 2));
    phases.push_back(std::move(p));
  }
  if (!header_seen) throw ReportError(fmt::format("{}: empty (no header)", source_name));
  return phases;
}

std::vector<ScriptPhase> read_script_phases(const std::filesystem::path& path) {
  return parse_script_phases(text::read_file(path), path.string());
}

SlideFigures slide_figures(const ScriptPhase& phase, const Series& sensor, const Series& pose) {
  if (!phase.force_N || !phase.normal || !phase.along)
    throw ReportError(fmt::format("the phase log's {} '{}' has no force, normal or direction", phase.motion,
                                  phase.description));
  SlideFigures out;
  out.phase = phase;
  const auto& n = *phase.normal;
  std::vector<double> errors;
  double applied_sum = 0;
  for (std::size_t i = 0; i < sensor.time_ns.size(); ++i) {
    if (sensor.time_ns[i] < phase.begin_ns || sensor.time_ns[i] > phase.end_ns) continue;
    const auto& w = sensor.values[i];
    const double applied = -(w[0] * n[0] + w[1] * n[1] + w[2] * n[2]);
    applied_sum += applied;
    errors.push_back(std::abs(*phase.force_N - applied));
  }
  out.force_samples = errors.size();
  if (!errors.empty()) {
    out.mean_applied_N = applied_sum / static_cast<double>(errors.size());
    out.error_p50_N = quantile(errors, 0.50);
    out.error_p99_N = quantile(errors, 0.99);
    out.error_max_N = *std::max_element(errors.begin(), errors.end());
  }
  const auto& d = *phase.along;
  std::vector<double> deviations;
  bool first = true;
  for (std::size_t i = 0; i < pose.time_ns.size(); ++i) {
    if (pose.time_ns[i] < phase.begin_ns || pose.time_ns[i] > phase.end_ns) continue;
    const std::array<double, 3> p{pose.values[i][0], pose.values[i][1], pose.values[i][2]};
    if (first) out.start_m = p;
    first = false;
    out.end_m = p;
    std::array<double, 3> off{p[0] - out.start_m[0], p[1] - out.start_m[1], p[2] - out.start_m[2]};
    const double s = dot(off, d);
    for (std::size_t k = 0; k < 3; ++k) off[k] -= s * d[k];
    deviations.push_back(std::sqrt(dot(off, off)));
  }
  out.pose_samples = deviations.size();
  if (!deviations.empty()) {
    const std::array<double, 3> run{out.end_m[0] - out.start_m[0], out.end_m[1] - out.start_m[1],
                                    out.end_m[2] - out.start_m[2]};
    out.travelled_m = dot(run, d);
    out.deviation_p99_m = quantile(deviations, 0.99);
    out.deviation_max_m = *std::max_element(deviations.begin(), deviations.end());
  }
  return out;
}

std::string format_script_report(const std::vector<ScriptPhase>& phases, const std::vector<SlideFigures>& slides,
                                 const ScriptLimits& limits, std::vector<std::string>& missed) {
  std::string out = "Motion script, each motion as the script ran it:\n";
  if (phases.empty()) out += "  (none: the script ran no motion)\n";
  const std::int64_t t0 = phases.empty() ? 0 : phases.front().begin_ns;
  for (const auto& p : phases) {
    out += fmt::format("  {:7.2f} s  {:6.2f} s  {:<8} {}\n", static_cast<double>(p.begin_ns - t0) * 1e-9,
                       static_cast<double>(p.end_ns - p.begin_ns) * 1e-9, p.outcome, p.description);
    if (p.outcome != "done") missed.push_back(fmt::format("the script's {} ended {}", p.description, p.outcome));
  }
  if (slides.empty()) {
    out += "Slides: none in the script\n";
    return out;
  }
  for (const auto& s : slides) {
    out += fmt::format("Slide '{}' ({} wrist samples, {} poses):\n", s.phase.description, s.force_samples,
                       s.pose_samples);
    out += fmt::format("  force along the normal: mean {:.2f} N for {:g} N; |error| p50 {:.3f} N, p99 {:.3f} N, "
                       "max {:.3f} N\n",
                       s.mean_applied_N, *s.phase.force_N, s.error_p50_N, s.error_p99_N, s.error_max_N);
    const bool force_ok = s.force_samples > 0 && s.error_p99_N <= limits.max_force_error_p99_N;
    out += fmt::format("  figure: force error along the normal while sliding, p99 {:.3f} N (<= {:g} N): {}\n",
                       s.error_p99_N, limits.max_force_error_p99_N, force_ok ? "ok" : "MISSED");
    if (!force_ok)
      missed.push_back(fmt::format("slide force error p99 {:.3f} N > {:g} N", s.error_p99_N,
                                   limits.max_force_error_p99_N));
    if (!s.deviation_max_m) {
      out += "  path: not measured (no pose recorded)\n";
      missed.push_back("slide path deviation: not measured (no pose recorded)");
      continue;
    }
    out += fmt::format("  path: from {} to {} mm, {:.1f} mm along {}; off the straight line p99 {:.3f} mm, max "
                       "{:.3f} mm\n",
                       vector_text(s.start_m, 1000), vector_text(s.end_m, 1000), *s.travelled_m * 1000,
                       vector_text(*s.phase.along, 1), *s.deviation_p99_m * 1000, *s.deviation_max_m * 1000);
    const bool path_ok = *s.deviation_max_m <= limits.max_deviation_m;
    out += fmt::format("  figure: path deviation, max {:.3f} mm (<= {:g} mm): {}\n", *s.deviation_max_m * 1000,
                       limits.max_deviation_m * 1000, path_ok ? "ok" : "MISSED");
    if (!path_ok)
      missed.push_back(fmt::format("slide path deviation {:.3f} mm > {:g} mm", *s.deviation_max_m * 1000,
                                   limits.max_deviation_m * 1000));
  }
  return out;
}

}  // namespace rtm::demo
