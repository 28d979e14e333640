// SPDX-License-Identifier: Apache-2.0
// A component's parameters, each declared once. One line names the parameter, points at the
// field of the component's parameters struct P that holds it (the struct's initialiser is its
// default), and gives its unit, what it is, when it may change and the values it may take.
// From that line come
//   - the option of every executable that runs the component (host/runner.h,
//     add_parameter_options(): --name with '-' for '_', "description [unit]" as its help, the
//     field's value as its default),
//   - the check of a value however it comes: the command line, `rtm set`, or code (validate()),
//   - what `rtm cat` shows and `rtm set` changes (Component::add_parameters),
//   - the typed value tests read: the struct's field.
//
//   struct GripParams { float force_N = 5; std::uint32_t settle_periods = 10; };
//   const rtm::ParameterTable<GripParams> kGripParameters{"grip", {
//       {"force", &GripParams::force_N, "N", "grip force", rtm::ParameterAccess::live, rtm::above(0)},
//       {"settle_periods", &GripParams::settle_periods, "cycles", "cycles to settle",
//        rtm::ParameterAccess::when_off, rtm::between(1, 1000)}}};
#pragma once

#include "rtm/describe.h"

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <variant>
#include <vector>

namespace rtm {

// The values a number may take: always finite; at least min (above it when min_open); at
// most max. A count (a whole number of cycles) takes them as whole numbers.
struct Bounds {
  double min = -std::numeric_limits<double>::infinity();
  bool min_open = false;
  double max = std::numeric_limits<double>::infinity();
};
constexpr Bounds any_finite() { return {}; }
constexpr Bounds at_least(double min) { return {.min = min}; }
constexpr Bounds above(double min) { return {.min = min, .min_open = true}; }
constexpr Bounds between(double min, double max) { return {.min = min, .max = max}; }

// Throws std::invalid_argument "<owner> <what> = <value> ..." when value breaks bounds: "is not
// a finite number", ": must be at least 0", "must be at least 1" (a count), ": at most 1000".
void check_bounds(double value, const Bounds& bounds, std::string_view owner, std::string_view what, bool count);

template <class P>
struct ParameterDecl {
  using Field = std::variant<std::array<float, 6> P::*, float P::*, std::uint32_t P::*>;

  // field: the member of P that holds the value (six numbers, one number, or a count).
  template <class T>
  ParameterDecl(std::string name_, T P::*field_, std::string unit_, std::string description_,
                ParameterAccess access_, Bounds bounds_ = {})
      : name(std::move(name_)),
        field(field_),
        unit(std::move(unit_)),
        description(std::move(description_)),
        access(access_),
        bounds(bounds_),
        get_(&get_of<T>),
        check_(&check_of<T>),
        parse_(&parse_of<T>) {}

  std::string name;         // snake_case: "contact_force"
  Field field;              // &P::contact_force_N
  std::string unit;         // "N"; "cycles" for a count
  std::string description;  // one line
  ParameterAccess access = ParameterAccess::fixed;
  Bounds bounds = {};

  // p's value as `rtm set` takes it: "0.003 0.003 0 0 0 0", "1", "3".
  std::string get(const P& p) const { return get_(*this, p); }
  // Throws std::invalid_argument naming owner, the parameter (and the element) and the value
  // when p's value breaks the bounds.
  void check(const P& p, std::string_view owner) const { check_(*this, p, owner); }
  // Parses text as `rtm set` gives it into p's field, checked; p is unchanged when it throws
  // (std::invalid_argument saying what is wrong).
  void set(P& p, std::string_view text, std::string_view owner) const {
    P changed = p;
    parse_(*this, changed, text);
    check(changed, owner);
    p = changed;
  }

 private:
  template <class T>
  static std::string get_of(const ParameterDecl& d, const P& p) {
    const T& v = p.*std::get<T P::*>(d.field);
    if constexpr (std::is_same_v<T, float>)
      return format_numbers(std::span<const float>(&v, 1));
    else if constexpr (std::is_integral_v<T>)
      return std::to_string(v);
    else
      return format_numbers(std::span<const float>(v));
  }
  template <class T>
  static void check_of(const ParameterDecl& d, const P& p, std::string_view owner) {
    const T& v = p.*std::get<T P::*>(d.field);
    if constexpr (std::is_same_v<T, float> || std::is_integral_v<T>) {
      check_bounds(static_cast<double>(v), d.bounds, owner, d.name, std::is_integral_v<T>);
    } else {
      for (std::size_t i = 0; i < v.size(); ++i)
        check_bounds(v[i], d.bounds, owner, d.name + "[" + std::to_string(i) + "]", false);
    }
  }
  template <class T>
  static void parse_of(const ParameterDecl& d, P& p, std::string_view text) {
    T& v = p.*std::get<T P::*>(d.field);
    if constexpr (std::is_integral_v<T>) {
      constexpr double kMax = std::numeric_limits<T>::max();
      v = static_cast<T>(parse_whole_number(text, static_cast<std::uint64_t>(std::max(d.bounds.min, 0.0)),
                                            static_cast<std::uint64_t>(std::min(d.bounds.max, kMax))));
    } else if constexpr (std::is_same_v<T, float>) {
      v = static_cast<float>(parse_numbers(text, 1)[0]);
    } else {
      const auto numbers = parse_numbers(text, v.size());
      for (std::size_t i = 0; i < v.size(); ++i) v[i] = static_cast<float>(numbers[i]);
    }
  }

  std::string (*get_)(const ParameterDecl&, const P&);
  void (*check_)(const ParameterDecl&, const P&, std::string_view);
  void (*parse_)(const ParameterDecl&, P&, std::string_view);
};

// The parameters of one kind of component, in the order `rtm cat` lists them.
template <class P>
class ParameterTable {
 public:
  // owner: the kind, as messages name it ("controller gain[2] = nan is not a finite number").
  // Throws std::invalid_argument for a name used twice.
  ParameterTable(std::string owner, std::vector<ParameterDecl<P>> entries)
      : owner_(std::move(owner)), entries_(std::move(entries)) {
    for (std::size_t i = 0; i < entries_.size(); ++i) {
      for (std::size_t j = 0; j < i; ++j) {
        if (entries_[i].name == entries_[j].name)
          throw std::invalid_argument(owner_ + ": parameter '" + entries_[i].name + "' declared twice");
      }
    }
  }

  const std::string& owner() const { return owner_; }
  const std::vector<ParameterDecl<P>>& entries() const { return entries_; }

  // Every value of p within its bounds; else std::invalid_argument naming the first that is not.
  void validate(const P& p) const {
    for (const auto& e : entries_) e.check(p, owner_);
  }

 private:
  std::string owner_;
  std::vector<ParameterDecl<P>> entries_;
};

}  // namespace rtm
