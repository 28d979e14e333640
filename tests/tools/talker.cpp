// rtm-test-talker: a component with ports of two types, for the `rtm` tool's tests.
//   in:  in0 (TimedFloat6), pos3 (TimedFloat3)
//   out: force (TimedFloat6, a ramp: value i of cycle n is n + i), out3 (TimedFloat3)
#include "rtm/data.h"
#include "rtm/runner.h"

#include <memory>

namespace {

class Talker final : public rtm::Component {
 public:
  explicit Talker(const std::string& name) : Component(name, "talker") {}

  void on_cycle(const rtm::CycleContext&) override {
    ++cycle_;
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
};

}  // namespace

int main(int argc, char** argv) {
  return rtm::run_component(argc, argv, {
      .kind = "talker",
      .description = "test component with TimedFloat6 and TimedFloat3 ports",
      .add_options = {},
      .create = [](const rtm::RunSettings& s) { return std::make_unique<Talker>(s.name); },
      .activity = {},
  });
}
