// SPDX-License-Identifier: Apache-2.0
// Self-description: what a port carries (a line of text and its elements with units), a
// component's named statistics and its parameters. Components declare them in their
// constructor; ComponentServant publishes them through RTMExt.idl (PortDescription,
// statistics(), parameters(), set_parameter()), and `rtm cat` shows them.
//
//   add_out_port<RTM::TimedFloat6>("wrench", {"wrench on the tool, base frame",
//                                             rtm::elements("fx fy fz tx ty tz", "N N N N·m N·m N·m")});
//   add_statistic("watchdog_events", "", "commands stopped arriving", [this] { return double(events_); });
//   add_parameter({.name = "gain", .unit = "(m/s)/N", .description = "...",
//                  .access = rtm::ParameterAccess::live, .get = ..., .set = ...});
// A component's own parameters are better declared once, in a table (rtm/parameters.h).
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <iosfwd>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace rtm {

// One element of a port's datum.
struct Element {
  std::string name;  // "fx"
  std::string unit;  // "N"; "" when dimensionless
};

// The words of text, separated by spaces, commas or tabs (lists of names, units, values, a
// connection policy's tokens).
std::vector<std::string> split_words(std::string_view text);

// Elements from two space-separated lists of the same length ("-" for no unit). Throws
// std::invalid_argument when the lengths differ or a list is empty.
std::vector<Element> elements(std::string_view names, std::string_view units);

// The elements of the six-vectors most force-control ports carry, in SI units.
std::vector<Element> wrench_elements();  // fx fy fz [N], tx ty tz [N·m]
std::vector<Element> twist_elements();   // vx vy vz [m/s], wx wy wz [rad/s]
std::vector<Element> pose_elements();    // x y z [m], rx ry rz [rad]: position, rotation vector

// What a port carries.
struct PortInfo {
  std::string description;         // one line
  std::vector<Element> elements;   // one per value of the datum, or none
};

// A count a component keeps, declared once: its field, the name of its statistic and what it
// means are one line of a CounterSet, which the component hands to Component::add_counters():
//
//   struct GainCounters : rtm::CounterSet {
//     rtm::Counter scaled{*this, "scaled", "data scaled"};
//   };
//
// Tests read the field (counters().scaled == 3u), `rtm cat` the statistic "scaled", with the
// description as its help. Counted and read relaxed from any thread; counting allocates nothing.
class CounterSet;
class Counter {
 public:
  Counter(CounterSet& set, std::string name, std::string description);
  Counter(const Counter&) = delete;
  Counter& operator=(const Counter&) = delete;

  // Counts n; returns the count after it (the event's number, for a log line).
  std::uint64_t add(std::uint64_t n = 1) { return value_.fetch_add(n, std::memory_order_relaxed) + n; }
  std::uint64_t value() const { return value_.load(std::memory_order_relaxed); }
  operator std::uint64_t() const { return value(); }  // reads as the count it is
  const std::string& name() const { return name_; }
  const std::string& description() const { return description_; }

 private:
  std::string name_;
  std::string description_;
  std::atomic<std::uint64_t> value_{0};
};
std::ostream& operator<<(std::ostream& out, const Counter& counter);  // the count

// The counters of one component, in the order they are declared. Not copyable: each Counter
// is known by its address.
class CounterSet {
 public:
  CounterSet() = default;
  CounterSet(const CounterSet&) = delete;
  CounterSet& operator=(const CounterSet&) = delete;
  const std::vector<const Counter*>& all() const { return counters_; }

 private:
  friend class Counter;
  std::vector<const Counter*> counters_;
};

inline Counter::Counter(CounterSet& set, std::string name, std::string description)
    : name_(std::move(name)), description_(std::move(description)) {
  set.counters_.push_back(this);
}

// A named figure, read from any thread while the component runs (read() must be safe there:
// atomics, or a snapshot under a lock the cycle does not hold).
struct Statistic {
  std::string name;         // snake_case
  std::string unit;         // "" for a count
  std::string description;  // one line
  std::function<double()> read;
};

// When set_parameter may change a parameter.
enum class ParameterAccess {
  fixed,     // only at start: a command-line option
  when_off,  // while the component is not ON (its on_start() picks the value up)
  live,      // any time: set() must hand the value to the cycle safely (see rt/live_value.h)
};

struct Parameter {
  std::string name = {};         // snake_case, e.g. "gain"
  std::string unit = {};
  std::string description = {};  // one line
  ParameterAccess access = ParameterAccess::fixed;
  std::function<std::string()> get = {};  // the value as set() takes it
  // Parses, checks and applies text; throws std::invalid_argument saying what is wrong and
  // changes nothing then. Not called for a fixed parameter.
  std::function<void(std::string_view text)> set = {};
};

// Numbers separated by spaces or commas, each finite. Throws std::invalid_argument naming
// the text when one is not a number, is NaN/inf, or when there are not exactly `count`
// (count 0: any number of them, at least one).
std::vector<double> parse_numbers(std::string_view text, std::size_t count = 0);
// One whole number in [min, max]; std::invalid_argument otherwise.
std::uint64_t parse_whole_number(std::string_view text, std::uint64_t min, std::uint64_t max);
// Numbers as parse_numbers() reads them: "0.003 0.003 0 0 0 0" (shortest exact form).
std::string format_numbers(std::span<const float> values);
std::string format_numbers(std::span<const double> values);

}  // namespace rtm
