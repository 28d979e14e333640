// SPDX-License-Identifier: Apache-2.0
// A component's parameters, each declared once: a field of its parameters struct that holds the
// value beside what it is (its name, unit, description, when it may change, the values it may
// take). From that one line come
//   - the option of every executable that runs the component (host/runner.h,
//     add_parameter_options(): --name with '-' for '_', "description [unit]" as its help, the
//     value as its default),
//   - the check of a value however it comes: the command line, `rtm set`, or code (validate()),
//   - what `rtm cat` shows and `rtm set` changes (Component::add_parameters),
//   - the typed value the cycle and the tests read (`params.force_N` is a float, `gain[2]` one
//     of six).
//
//   struct GripParams {
//     rtm::Param<float> force_N{5, {"force", "N", "grip force", rtm::ParameterAccess::live, rtm::above(0)}};
//     rtm::Param<std::uint32_t> settle_periods{
//         10, {"settle_periods", "cycles", "cycles to settle", rtm::ParameterAccess::when_off, rtm::between(1, 1000)}};
//   };
//   const rtm::ParameterTable<GripParams> kGripParameters{"grip"};
//
// The struct holds nothing but rtm::Param fields (at most kMaxParameters), so that the table finds
// them without a list of its own. It stays trivially copyable: the cycle takes it whole.
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
#include <utility>
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
// An empty owner leaves it out ("gain[2] = nan is not a finite number").
void check_bounds(double value, const Bounds& bounds, std::string_view owner, std::string_view what, bool count);

// What a parameter is. The texts are literals: a copy of the struct copies views of them.
struct ParameterSpec {
  std::string_view name;         // snake_case: "contact_force"
  std::string_view unit;         // "N"; "cycles" for a count
  std::string_view description;  // one line
  ParameterAccess access = ParameterAccess::fixed;
  Bounds bounds = {};
};

template <class P>
class ParameterTable;

// A parameter's value (T: float, a count std::uint32_t, or six numbers std::array<float, 6>)
// with its declaration. Reads as a const T&; assigning a T changes the value. The declaration
// that counts is the one the struct's initialiser gives the field: only ParameterTable reads it,
// from a default-made struct, so a field assigned from another (`gain = free_gain`) takes its
// value and nothing else that matters.
template <class T>
  requires std::is_same_v<T, float> || std::is_same_v<T, std::uint32_t> || std::is_same_v<T, std::array<float, 6>>
class Param {
 public:
  constexpr Param(T initial, const ParameterSpec& spec) : value_(initial), spec_(spec) {}
  constexpr Param& operator=(const T& value) {
    value_ = value;
    return *this;
  }

  constexpr operator const T&() const { return value_; }  // NOLINT(google-explicit-constructor)
  constexpr const T& value() const { return value_; }
  constexpr T& value() { return value_; }

  constexpr float operator[](std::size_t i) const
    requires(!std::is_arithmetic_v<T>)
  {
    return value_[i];
  }
  constexpr float& operator[](std::size_t i)
    requires(!std::is_arithmetic_v<T>)
  {
    return value_[i];
  }
  friend constexpr bool operator==(const Param& a, const T& b) { return a.value_ == b; }

 private:
  template <class P>
  friend class ParameterTable;
  T value_;
  ParameterSpec spec_;
};

inline constexpr std::size_t kMaxParameters = 8;

namespace detail {
// Converts to any Param: only named where nothing is evaluated, to count a struct's fields.
struct AnyParam {
  template <class T>
  operator Param<T>() const;  // NOLINT(google-explicit-constructor)
};
template <std::size_t>
using AnyParamAt = AnyParam;
template <class P, std::size_t... I>
constexpr bool initialisable_from(std::index_sequence<I...>) {
  return requires { P{AnyParamAt<I>{}...}; };
}
// The number of leading Param fields of the aggregate P.
template <class P, std::size_t N = 0>
constexpr std::size_t param_count() {
  if constexpr (N < kMaxParameters + 1 && initialisable_from<P>(std::make_index_sequence<N + 1>{}))
    return param_count<P, N + 1>();
  else
    return N;
}
}  // namespace detail

// Calls f(param) for each Param field of p, in the struct's order (p: a parameters struct).
template <class P, class F>
constexpr void for_each_param(P& p, F&& f) {
  constexpr std::size_t n = detail::param_count<std::remove_const_t<P>>();
  static_assert(n >= 1 && n <= kMaxParameters,
                "a parameters struct holds 1 to kMaxParameters fields, each an rtm::Param, and nothing else");
  // A struct with a field that is not a Param has more fields than n: the binding below refuses it.
  if constexpr (n == 1) {
    auto& [a] = p;
    f(a);
  } else if constexpr (n == 2) {
    auto& [a, b] = p;
    (f(a), f(b));
  } else if constexpr (n == 3) {
    auto& [a, b, c] = p;
    (f(a), f(b), f(c));
  } else if constexpr (n == 4) {
    auto& [a, b, c, d] = p;
    (f(a), f(b), f(c), f(d));
  } else if constexpr (n == 5) {
    auto& [a, b, c, d, e] = p;
    (f(a), f(b), f(c), f(d), f(e));
  } else if constexpr (n == 6) {
    auto& [a, b, c, d, e, g] = p;
    (f(a), f(b), f(c), f(d), f(e), f(g));
  } else if constexpr (n == 7) {
    auto& [a, b, c, d, e, g, h] = p;
    (f(a), f(b), f(c), f(d), f(e), f(g), f(h));
  } else {
    auto& [a, b, c, d, e, g, h, i] = p;
    (f(a), f(b), f(c), f(d), f(e), f(g), f(h), f(i));
  }
}

// One parameter of a table: its declaration and where it is in the struct.
template <class P>
struct ParameterDecl {
  std::string name;
  std::string unit;
  std::string description;
  ParameterAccess access = ParameterAccess::fixed;
  Bounds bounds = {};
  std::size_t index = 0;  // the field's position in P

  // Calls f(param), param being this parameter's Param field of p.
  template <class Q, class F>
    requires std::is_same_v<std::remove_const_t<Q>, P>
  void visit(Q& p, F&& f) const {
    std::size_t i = 0;
    for_each_param(p, [&](auto& param) {
      if (i++ == index) f(param);
    });
  }

  // p's value as `rtm set` takes it: "0.003 0.003 0 0 0 0", "1", "3".
  std::string get(const P& p) const {
    std::string text;
    visit(p, [&](const auto& param) {
      const auto& v = param.value();
      using T = std::remove_cvref_t<decltype(v)>;
      if constexpr (std::is_same_v<T, float>)
        text = format_numbers(std::span<const float>(&v, 1));
      else if constexpr (std::is_integral_v<T>)
        text = std::to_string(v);
      else
        text = format_numbers(std::span<const float>(v));
    });
    return text;
  }
  // Throws std::invalid_argument naming owner, the parameter (and the element) and the value
  // when p's value breaks the bounds.
  void check(const P& p, std::string_view owner) const {
    visit(p, [&](const auto& param) {
      const auto& v = param.value();
      using T = std::remove_cvref_t<decltype(v)>;
      if constexpr (std::is_arithmetic_v<T>) {
        check_bounds(static_cast<double>(v), bounds, owner, name, std::is_integral_v<T>);
      } else {
        for (std::size_t i = 0; i < v.size(); ++i)
          check_bounds(v[i], bounds, owner, name + "[" + std::to_string(i) + "]", false);
      }
    });
  }
  // Parses text as `rtm set` gives it into p's field, checked; p is unchanged when it throws
  // (std::invalid_argument saying what is wrong, after the parameter's name: "gain: '1 2' holds
  // 2 numbers; 6 expected", "gain[2] = nan is not a finite number"; owner before it when given).
  void set(P& p, std::string_view text, std::string_view owner) const {
    P changed = p;
    try {
      parse_into(changed, text);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument((owner.empty() ? name : std::string(owner) + " " + name) + ": " + e.what());
    }
    check(changed, owner);
    p = changed;
  }

 private:
  void parse_into(P& changed, std::string_view text) const {
    visit(changed, [&](auto& param) {
      auto& v = param.value();
      using T = std::remove_cvref_t<decltype(v)>;
      if constexpr (std::is_integral_v<T>) {
        constexpr double kMax = std::numeric_limits<T>::max();
        v = static_cast<T>(parse_whole_number(text, static_cast<std::uint64_t>(std::max(bounds.min, 0.0)),
                                              static_cast<std::uint64_t>(std::min(bounds.max, kMax))));
      } else if constexpr (std::is_same_v<T, float>) {
        v = static_cast<float>(parse_numbers(text, 1)[0]);
      } else {
        const auto numbers = parse_numbers(text, v.size());
        for (std::size_t i = 0; i < v.size(); ++i) v[i] = static_cast<float>(numbers[i]);
      }
    });
  }
};

// The parameters of one kind of component, found in its struct P, in the struct's order (the
// order `rtm cat` lists them in).
template <class P>
class ParameterTable {
 public:
  // owner: the kind, as messages name it ("controller gain[2] = nan is not a finite number").
  // Throws std::invalid_argument for a name used twice.
  explicit ParameterTable(std::string owner) : owner_(std::move(owner)) {
    const P defaults{};
    for_each_param(defaults, [&](const auto& param) {
      const ParameterSpec& s = param.spec_;
      for (const auto& e : entries_) {
        if (e.name == s.name)
          throw std::invalid_argument(owner_ + ": parameter '" + e.name + "' declared twice");
      }
      entries_.push_back({.name = std::string(s.name),
                          .unit = std::string(s.unit),
                          .description = std::string(s.description),
                          .access = s.access,
                          .bounds = s.bounds,
                          .index = entries_.size()});
    });
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
