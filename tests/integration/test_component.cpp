// SPDX-License-Identifier: Apache-2.0
// rtm-test-component: the component the integration tests run as a real process.
//
// Ports:
//   out0  OutPort  TimedFloat6  while on, a ramp each cycle: val[i] = cycle + i, stamped now
//   echo  OutPort  TimedFloat6  each new datum read from in0, written back unchanged
//   in0   InPort   TimedFloat6  latest value
//   in3   InPort   TimedFloat3  latest value (for type-mismatch checks)
// --also-bind NAME (repeatable): the runner's on_activated hook binds the component under NAME
// too; a NAME equal to --name is refused by its validate hook.
#include "rtm/data.h"
#include "host/runner.h"

#include <stdexcept>
#include <string>
#include <vector>

namespace {

class TestComponent final : public rtm::Component {
 public:
  explicit TestComponent(std::string name) : Component(std::move(name), "test") {}

  void on_cycle(const rtm::CycleContext&) override {
    for (CORBA::ULong i = 0; i < 6; ++i) ramp_.val[i] = static_cast<float>(cycle_ + i);
    ++cycle_;
    ramp_.tm = rtm::now();
    out_.write(ramp_);
    if (in_.read(received_) == rtm::ReadResult::NewData) echo_.write(received_);
    in3_.read(received3_);
  }

 private:
  std::uint64_t cycle_ = 0;
  RTM::TimedFloat6 ramp_{};
  RTM::TimedFloat6 received_{};
  RTM::TimedFloat3 received3_{};
  rtm::OutPort<RTM::TimedFloat6>& out_ = add_out_port<RTM::TimedFloat6>("out0");
  rtm::OutPort<RTM::TimedFloat6>& echo_ = add_out_port<RTM::TimedFloat6>("echo");
  rtm::InPort<RTM::TimedFloat6>& in_ = add_in_port<RTM::TimedFloat6>("in0");
  rtm::InPort<RTM::TimedFloat3>& in3_ = add_in_port<RTM::TimedFloat3>("in3");
};

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> also_bind;
  return rtm::run_component(argc, argv, {
      .kind = "test",
      .description = "rtm-test-component: ramp on out0, in0 echoed on echo, in3 takes TimedFloat3",
      .add_options =
          [&](CLI::App& app) { app.add_option("--also-bind", also_bind, "bind the component under this name too"); },
      .validate =
          [&](const rtm::RunSettings& settings) {
            for (const auto& name : also_bind) {
              if (name == settings.name) throw std::invalid_argument("--also-bind " + name + " is the component's own name");
            }
          },
      .create = [](const rtm::RunSettings& settings) { return std::make_unique<TestComponent>(settings.name); },
      .on_activated =
          [&](rtm::ComponentServant& servant, const rtm::RunContext&) {
            std::vector<rtm::ExtraName> names;
            for (const auto& name : also_bind) names.push_back({name, servant.reference()});
            return names;
          },
  });
}
