// SPDX-License-Identifier: Apache-2.0
// rtm-test-talker: a component with ports of two types, for the `rtm` tool's tests.
//   in:  in0 (TimedFloat6, undescribed), pos3 (TimedFloat3, x y z in m)
//   out: force (TimedFloat6, a ramp: value i of cycle n is n + i + offset; fx..tz in N, N·m),
//        out3 (TimedFloat3)
// Statistic "cycles"; parameters "offset" (live), "fail_after" (while off), "name" (fixed) and
// "spin_us" (live: each cycle first spins that long). --stamp-age-ms N stamps its samples N ms
// ago. It never copies in0's stamp to force: in a chain's middle, the runner's --stamp-from
// (which rtm up gives from the system file's chains) does.
// --fail-after N makes its N-th cycle throw (the component goes to COMPONENT_ERROR);
// --in0-delay-ms N makes in0 a reader slow to take its data: each put waits N ms (its writer's
// calls time out, while the component answers everything else).
#include "rt/clock.h"
#include "rt/live_value.h"
#include "rtm/data.h"
#include "host/module.h"

#include <atomic>
#include <memory>
#include <span>
#include <stdexcept>
#include <thread>

namespace {

class Talker final : public rtm::Component {
 public:
  Talker(const std::string& name, long fail_after, int in0_delay_ms, int stamp_age_ms = 0)
      : Component(name, "talker"),
        in0_(add_in_port<RTM::TimedFloat6>("in0", in0_policy(in0_delay_ms))),
        fail_after_(fail_after),
        stamp_age_ns_(static_cast<std::int64_t>(stamp_age_ms) * 1'000'000) {
    add_statistic("cycles", "", "cycles run", [this] { return static_cast<double>(cycles_.load()); });
    add_parameter({.name = "offset",
                   .unit = "N",
                   .description = "added to every value of force",
                   .access = rtm::ParameterAccess::live,
                   .get = [this] { return rtm::format_numbers(std::span<const float>(&offset_shown_, 1)); },
                   .set = [this](std::string_view text) {
                     offset_shown_ = static_cast<float>(rtm::parse_numbers(text, 1)[0]);
                     offset_live_.publish(offset_shown_);
                   }});
    add_parameter({.name = "fail_after",
                   .unit = "cycles",
                   .description = "throw in every N-th cycle (0: never)",
                   .access = rtm::ParameterAccess::when_off,
                   .get = [this] { return std::to_string(fail_after_); },
                   .set = [this](std::string_view text) {
                     fail_after_ = static_cast<long>(rtm::parse_whole_number(text, 0, 1'000'000));
                   }});
    add_parameter({.name = "name", .description = "the name it is bound as", .get = [this] { return this->name(); }});
    add_parameter({.name = "spin_us",
                   .unit = "us",
                   .description = "each cycle first spins this long on the CPU (a cycle slowed past its budget)",
                   .access = rtm::ParameterAccess::live,
                   .get = [this] { return std::to_string(spin_us_.load()); },
                   .set = [this](std::string_view text) {
                     spin_us_.store(static_cast<long>(rtm::parse_whole_number(text, 0, 1'000'000)));
                   }});
  }

  void on_cycle(const rtm::CycleContext&) override {
    in0_.read(last_in_);
    // Busy, not asleep: the cycle takes at least this long whatever the machine does, between
    // reading its input and writing what derives from it.
    const std::int64_t spin_until = rtm::monotonic_ns() + spin_us_.load() * 1000;
    while (rtm::monotonic_ns() < spin_until) {
    }
    ++cycle_;
    cycles_.store(cycle_);
    if (fail_after_ > 0 && cycle_ % fail_after_ == 0) {
      throw std::runtime_error("talker failed on purpose at cycle " + std::to_string(cycle_));
    }
    offset_live_.take(offset_);
    force_sample_.tm = rtm::from_ns(rtm::to_ns(rtm::now()) - stamp_age_ns_);
    for (int i = 0; i < 6; ++i) force_sample_.val[i] = static_cast<float>(cycle_ + i) + offset_;
    force_.write(force_sample_);
  }

 private:
  static rtm::InPortPolicy in0_policy(int delay_ms) {
    if (delay_ms <= 0) return rtm::InPortPolicy::latest();
    return rtm::InPortPolicy::callback<RTM::TimedFloat6>(
        [delay_ms](const RTM::TimedFloat6&) { std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms)); });
  }

  rtm::InPort<RTM::TimedFloat6>& in0_;
  rtm::InPort<RTM::TimedFloat3>& pos3_ =
      add_in_port<RTM::TimedFloat3>("pos3", {"a position", rtm::elements("x y z", "m m m")});
  rtm::OutPort<RTM::TimedFloat6>& force_ = add_out_port<RTM::TimedFloat6>(
      "force", {"a ramp: value i of cycle n is n + i + offset", rtm::elements("fx fy fz tx ty tz", "N N N N·m N·m N·m")});
  rtm::OutPort<RTM::TimedFloat3>& out3_ = add_out_port<RTM::TimedFloat3>("out3");
  RTM::TimedFloat6 force_sample_{};
  RTM::TimedFloat6 last_in_{};
  long cycle_ = 0;
  std::atomic<long> cycles_{0};
  std::atomic<long> spin_us_{0};
  long fail_after_;  // changes only while off
  std::int64_t stamp_age_ns_;  // its own samples are stamped this long ago
  float offset_ = 0;        // the cycle's
  float offset_shown_ = 0;  // the last set (set_parameter calls are serialised)
  rtm::LiveValue<float> offset_live_{0.0f};
};

// A program (rtm-test-talker) and a module for rtm-container (rtm-test-talker.so).
rtm::ComponentMain talker() {
  struct Options {
    long fail_after = 0;
    int in0_delay_ms = 0;
    int stamp_age_ms = 0;
  };
  auto options = std::make_shared<Options>();
  return {
      .kind = "talker",
      .description = "test component with TimedFloat6 and TimedFloat3 ports",
      .add_options = [options](CLI::App& app) {
        app.add_option("--fail-after", options->fail_after, "throw in every N-th cycle (0: never)");
        app.add_option("--in0-delay-ms", options->in0_delay_ms, "each put into in0 waits this long (a slow reader)");
        app.add_option("--stamp-age-ms", options->stamp_age_ms, "stamp its own force samples this long ago");
      },
      .create = [options](const rtm::RunSettings& s) {
        return std::make_unique<Talker>(s.name, options->fail_after, options->in0_delay_ms, options->stamp_age_ms);
      },
      .activity = {},
  };
}

}  // namespace

RTM_COMPONENT(talker)
