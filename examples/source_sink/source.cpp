// SPDX-License-Identifier: Apache-2.0
// rtm-example-source: writes a TimedFloat6 ramp on OutPort "out0" every period while on.
// val[i] = (cycle + i) * step, so each datum can be told from the one before.
#include "rtm/data.h"
#include "host/module.h"

#include <memory>
#include <string>

namespace {

class RampSource final : public rtm::Component {
 public:
  RampSource(std::string name, float step) : Component(std::move(name), "source"), step_(step) {}

  void on_start() override { cycle_ = 0; }
  void on_cycle(const rtm::CycleContext&) override {
    for (CORBA::ULong i = 0; i < 6; ++i) datum_.val[i] = static_cast<float>(cycle_ + i) * step_;
    ++cycle_;
    datum_.tm = rtm::now();
    out_.write(datum_);
  }

 private:
  const float step_;
  std::uint64_t cycle_ = 0;
  RTM::TimedFloat6 datum_{};
  rtm::OutPort<RTM::TimedFloat6>& out_ = add_out_port<RTM::TimedFloat6>("out0");
};

// The program, and the module rtm-container loads: each component made has its own step.
rtm::ComponentMain source() {
  auto step = std::make_shared<float>(0.001f);
  return {
      .kind = "source",
      .description = "rtm-example-source: writes a TimedFloat6 ramp on out0 every period",
      .add_options = [step](CLI::App& app) { app.add_option("--step", *step, "ramp increment per cycle")->capture_default_str(); },
      .create = [step](const rtm::RunSettings& settings) { return std::make_unique<RampSource>(settings.name, *step); },
  };
}

}  // namespace

RTM_COMPONENT(source)
