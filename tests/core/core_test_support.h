// SPDX-License-Identifier: Apache-2.0
// Helpers shared by the rtm_core unit tests.
#pragma once

#include "rtm/component.h"
#include "rtm/data.h"
#include "rtm/inport.h"
#include "rtm/orb.h"
#include "rtm/outport.h"

#include <gtest/gtest.h>

#include "rtm_test/eventually.h"

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <stdexcept>
#include <thread>

namespace rtm::test {

using rtm_test::eventually;

// The ports most of these tests wire: the paper's six numbers.
using In6 = rtm::InPort<RTM::TimedFloat6>;
using Out6 = rtm::OutPort<RTM::TimedFloat6>;

// A real ORB for the tests of one suite (no naming service needed).
class OrbTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { orb_ = new Orb(); }
  static void TearDownTestSuite() {
    delete orb_;
    orb_ = nullptr;
  }
  static Orb& orb() { return *orb_; }
  static inline Orb* orb_ = nullptr;
};

inline RTM::TimedFloat6 float6(float first, std::uint32_t sec = 1) {
  RTM::TimedFloat6 d{};
  d.tm.sec = sec;
  d.tm.nsec = 0;
  for (int i = 0; i < 6; ++i) d.val[i] = first + static_cast<float>(i);
  return d;
}

inline RTM::TimedFloat3 float3(float first) {
  RTM::TimedFloat3 d{};
  for (int i = 0; i < 3; ++i) d.val[i] = first + static_cast<float>(i);
  return d;
}

// Reads a TimedFloat6 in0, writes 2 * it on out0; can be told to throw in a given cycle.
// A 1 ms period: the tests' activities cycle fast.
inline PeriodicOptions fast() {
  PeriodicOptions o;
  o.period_ns = 1'000'000;
  return o;
}

class Doubler final : public Component {
 public:
  explicit Doubler(std::string name = "doubler0", InPortPolicy policy = InPortPolicy::latest())
      : Component(std::move(name), "controller"),
        in(add_in_port<RTM::TimedFloat6>("in0", std::move(policy))),
        out(add_out_port<RTM::TimedFloat6>("out0")) {}

  void on_start() override {
    if (throw_on_start.load()) throw std::runtime_error("injected failure in on_start");
    starts.fetch_add(1);
  }
  void on_stop() override { stops.fetch_add(1); }
  void on_cycle(const CycleContext&) override {
    const auto n = cycles.fetch_add(1) + 1;
    if (n == throw_at_cycle.load()) throw std::runtime_error("injected failure in cycle " + std::to_string(n));
    RTM::TimedFloat6 d{};
    while (in.read(d) == ReadResult::NewData) {
      for (auto& v : d.val) v *= 2.0f;
      out.write(d);
    }
  }

  InPort<RTM::TimedFloat6>& in;
  OutPort<RTM::TimedFloat6>& out;
  std::atomic<long> cycles{0};
  std::atomic<long> throw_at_cycle{-1};
  std::atomic<bool> throw_on_start{false};
  std::atomic<int> starts{0};
  std::atomic<int> stops{0};
};

}  // namespace rtm::test
