// SPDX-License-Identifier: Apache-2.0
#include "rtm/describe.h"
#include "rtm/parameters.h"

#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <ostream>
#include <stdexcept>

namespace rtm {

namespace {

template <class T>
std::string format_all(std::span<const T> values) {
  std::string out;
  for (std::size_t i = 0; i < values.size(); ++i) out += fmt::format("{}{}", i == 0 ? "" : " ", values[i]);
  return out;
}

}  // namespace

std::vector<std::string> split_words(std::string_view text) {
  std::vector<std::string> out;
  std::size_t i = 0;
  while (i < text.size()) {
    while (i < text.size() && (text[i] == ' ' || text[i] == ',' || text[i] == '\t')) ++i;
    std::size_t end = i;
    while (end < text.size() && text[end] != ' ' && text[end] != ',' && text[end] != '\t') ++end;
    if (end > i) out.emplace_back(text.substr(i, end - i));
    i = end;
  }
  return out;
}

std::vector<Element> elements(std::string_view names, std::string_view units) {
  const auto n = split_words(names);
  const auto u = split_words(units);
  if (n.empty() || n.size() != u.size())
    throw std::invalid_argument(fmt::format("elements: {} names ('{}') but {} units ('{}')", n.size(), names,
                                            u.size(), units));
  std::vector<Element> out;
  for (std::size_t i = 0; i < n.size(); ++i) out.push_back({n[i], u[i] == "-" ? "" : u[i]});
  return out;
}

std::vector<Element> wrench_elements() { return elements("fx fy fz tx ty tz", "N N N N·m N·m N·m"); }
std::vector<Element> twist_elements() { return elements("vx vy vz wx wy wz", "m/s m/s m/s rad/s rad/s rad/s"); }
std::vector<Element> pose_elements() { return elements("x y z rx ry rz", "m m m rad rad rad"); }

std::vector<double> parse_numbers(std::string_view text, std::size_t count) {
  std::vector<double> out;
  for (const auto& w : split_words(text)) {
    double v = 0;
    const auto [end, ec] = std::from_chars(w.data(), w.data() + w.size(), v);
    if (ec != std::errc{} || end != w.data() + w.size())
      throw std::invalid_argument(fmt::format("'{}' is not a number (in '{}')", w, text));
    if (!std::isfinite(v)) throw std::invalid_argument(fmt::format("'{}' is not a finite number", w));
    out.push_back(v);
  }
  if (count == 0 && out.empty()) throw std::invalid_argument(fmt::format("'{}' holds no number", text));
  if (count != 0 && out.size() != count)
    throw std::invalid_argument(fmt::format("'{}' holds {} numbers; {} expected", text, out.size(), count));
  return out;
}

std::uint64_t parse_whole_number(std::string_view text, std::uint64_t min, std::uint64_t max) {
  const double v = parse_numbers(text, 1)[0];
  if (v < static_cast<double>(min) || v > static_cast<double>(max) || v != std::floor(v))
    throw std::invalid_argument(fmt::format("'{}': a whole number from {} to {} is expected", text, min, max));
  return static_cast<std::uint64_t>(v);
}

void check_bounds(double value, const Bounds& bounds, std::string_view owner, std::string_view what, bool count) {
  const std::string who = owner.empty() ? std::string(what) : fmt::format("{} {}", owner, what);
  if (!std::isfinite(value)) throw std::invalid_argument(fmt::format("{} = {} is not a finite number", who, value));
  if (count && value < bounds.min) throw std::invalid_argument(fmt::format("{} must be at least {}", who, bounds.min));
  if (bounds.min_open ? !(value > bounds.min) : value < bounds.min) {
    throw std::invalid_argument(
        fmt::format("{} = {}: must be {} {}", who, value, bounds.min_open ? "above" : "at least", bounds.min));
  }
  if (value > bounds.max) throw std::invalid_argument(fmt::format("{} = {}: at most {}", who, value, bounds.max));
}

std::string format_numbers(std::span<const float> values) { return format_all(values); }
std::string format_numbers(std::span<const double> values) { return format_all(values); }

std::ostream& operator<<(std::ostream& out, const Counter& counter) { return out << counter.value(); }

}  // namespace rtm
