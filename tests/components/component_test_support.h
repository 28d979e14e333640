// Small helpers shared by the component tests: TimedFloat6 values and a cycle context.
#pragma once

#include "rt/activity.h"
#include "rtm/data.h"

#include <array>

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

inline rtm::CycleContext cycle(std::uint64_t n) {
  rtm::CycleContext ctx;
  ctx.cycle = n;
  ctx.period_ns = 2'000'000;
  return ctx;
}

}  // namespace comp_test
