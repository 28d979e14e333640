// SPDX-License-Identifier: Apache-2.0
// Small helpers shared by the component tests: TimedFloat6 values and a cycle context.
#pragma once

#include "rt/activity.h"
#include "rtm/component.h"
#include "rtm/data.h"

#include <array>
#include <stdexcept>
#include <string>

namespace comp_test {

inline RTM::TimedFloat6 float6(std::array<float, 6> v, std::int64_t stamp_ns = 0) {
  RTM::TimedFloat6 d{};
  d.tm = stamp_ns == 0 ? rtm::now() : rtm::from_ns(stamp_ns);
  for (CORBA::ULong i = 0; i < 6; ++i) d.val[i] = v[i];
  return d;
}

inline std::array<float, 6> values(const RTM::TimedFloat6& d) {
  std::array<float, 6> v{};
  for (CORBA::ULong i = 0; i < 6; ++i) v[i] = d.val[i];
  return v;
}

// The parameter and statistic a component publishes (what `rtm cat` and `rtm set` reach).
inline const rtm::Parameter& parameter(const rtm::Component& c, const std::string& name) {
  for (const auto& p : c.parameters())
    if (p.name == name) return p;
  throw std::out_of_range("no parameter " + name);
}
inline double statistic(const rtm::Component& c, const std::string& name) {
  for (const auto& s : c.statistics())
    if (s.name == name) return s.read();
  throw std::out_of_range("no statistic " + name);
}

inline rtm::CycleContext cycle(std::uint64_t n) {
  rtm::CycleContext ctx;
  ctx.cycle = n;
  ctx.period_ns = 2'000'000;
  return ctx;
}

}  // namespace comp_test
