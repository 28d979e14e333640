// SPDX-License-Identifier: Apache-2.0
// rtm-example-sink: prints the TimedFloat6 data reaching InPort "in0".
//
// Printing is this example's whole purpose, so unlike a control component its cycle does
// I/O: at most one line per --print-every, with how many data arrived since the last line
// and how old the newest one was.
#include "rtm/data.h"
#include "host/module.h"

#include <memory>
#include <string>

#include <cstdio>

namespace {

class PrintingSink final : public rtm::Component {
 public:
  PrintingSink(std::string name, std::int64_t print_every_ns)
      : Component(std::move(name), "sink"), print_every_ns_(print_every_ns) {}

  void on_cycle(const rtm::CycleContext& ctx) override {
    if (ctx.wake_ns < next_print_ns_) return;
    next_print_ns_ = ctx.wake_ns + print_every_ns_;
    const auto counters = in_.counters_snapshot();
    const auto arrived = counters.accepted - accepted_at_last_print_;
    accepted_at_last_print_ = counters.accepted;
    if (in_.read(datum_) != rtm::ReadResult::NewData) {
      std::printf("%s: no new data\n", name().c_str());
    } else {
      const double age_us = static_cast<double>(rtm::to_ns(rtm::now()) - rtm::to_ns(datum_.tm)) / 1e3;
      std::printf("%s: %llu new, latest [%.3f %.3f %.3f %.3f %.3f %.3f] %.0f us old\n", name().c_str(),
                  static_cast<unsigned long long>(arrived), datum_.val[0], datum_.val[1], datum_.val[2],
                  datum_.val[3], datum_.val[4], datum_.val[5], age_us);
    }
    std::fflush(stdout);
  }

 private:
  const std::int64_t print_every_ns_;
  std::int64_t next_print_ns_ = 0;
  std::uint64_t accepted_at_last_print_ = 0;
  RTM::TimedFloat6 datum_{};
  rtm::InPort<RTM::TimedFloat6>& in_ = add_in_port<RTM::TimedFloat6>("in0");
};

// The program, and the module rtm-container loads: each component made has its own interval.
rtm::ComponentMain sink() {
  auto print_every = std::make_shared<std::string>("500ms");
  return {
      .kind = "sink",
      .description = "rtm-example-sink: prints the TimedFloat6 data reaching in0",
      .add_options = [print_every](CLI::App& app) {
        app.add_option("--print-every", *print_every, "at most one line per this interval")->capture_default_str();
      },
      .create = [print_every](const rtm::RunSettings& settings) {
        return std::make_unique<PrintingSink>(settings.name, rtm::parse_period_ns(*print_every));
      },
  };
}

}  // namespace

RTM_COMPONENT(sink)
