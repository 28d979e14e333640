// rtm-test-talker: a component with ports of two types, for the `rtm` tool's tests.
//   in:  in0 (TimedFloat6), pos3 (TimedFloat3)
//   out: force (TimedFloat6, a ramp: value i of cycle n is n + i), out3 (TimedFloat3)
// --fail-after N makes its N-th cycle throw (the component goes to COMPONENT_ERROR).
#include "rtm/data.h"
#include "rtm/runner.h"

#include <memory>
#include <stdexcept>

namespace {

class Talker final : public rtm::Component {
 public:
  Talker(const std::string& name, long fail_after)
      : Component(name, "talker"), fail_after_(fail_after) {}

  void on_cycle(const rtm::CycleContext&) override {
    ++cycle_;
    if (fail_after_ > 0 && cycle_ % fail_after_ == 0) {
      throw std::runtime_error("talker failed on purpose at cycle " + std::to_string(cycle_));
    }
    force_sample_.tm = rtm::now();
    for (int i = 0; i < 6; ++i) force_sample_.val[i] = static_cast<float>(cycle_ + i);
    force_.write(force_sample_);
    in0_.read(last_in_);
  }

 private:
  rtm::InPort<RTM::TimedFloat6>& in0_ = add_in_port<RTM::TimedFloat6>("in0");
  rtm::InPort<RTM::TimedFloat3>& pos3_ = add_in_port<RTM::TimedFloat3>("pos3");
  rtm::OutPort<RTM::TimedFloat6>& force_ = add_out_port<RTM::TimedFloat6>("force");
  rtm::OutPort<RTM::TimedFloat3>& out3_ = add_out_port<RTM::TimedFloat3>("out3");
  RTM::TimedFloat6 force_sample_{};
  RTM::TimedFloat6 last_in_{};
  long cycle_ = 0;
  const long fail_after_;
};

}  // namespace

int main(int argc, char** argv) {
  long fail_after = 0;
  return rtm::run_component(argc, argv, {
      .kind = "talker",
      .description = "test component with TimedFloat6 and TimedFloat3 ports",
      .add_options = [&](CLI::App& app) {
        app.add_option("--fail-after", fail_after, "throw in every N-th cycle (0: never)");
      },
      .create = [&](const rtm::RunSettings& s) { return std::make_unique<Talker>(s.name, fail_after); },
      .activity = {},
  });
}
