// SPDX-License-Identifier: Apache-2.0
// pose-relay: writes a TimedPose on out0 each cycle: a ramp on x until a datum reaches in0, then
// that datum (re-stamped), so that a put comes back on a get.
// The rtm headers come first, the stub header after them: the order does not matter.
#include "host/runner.h"
#include "rtm/data.h"

#include <TimedPose.hh>

RTM_DATA_TYPE(My, TimedPose, 7);

namespace {

class PoseRelay final : public rtm::Component {
 public:
  explicit PoseRelay(std::string name) : Component(std::move(name), "pose-relay") {}

  void on_cycle(const rtm::CycleContext&) override {
    My::TimedPose got{};
    if (in_.read(got) == rtm::ReadResult::NewData) {
      pose_ = got;
      echoing_ = true;
    }
    if (!echoing_) {
      pose_.p.x = 0.001 * static_cast<double>(++cycle_);
      pose_.p.y = 0.5;
      pose_.p.z = -0.25;
      pose_.q[0] = 1.0;
    }
    pose_.tm = rtm::now();
    out_.write(pose_);
  }

 private:
  std::uint64_t cycle_ = 0;
  bool echoing_ = false;
  My::TimedPose pose_{};
  rtm::InPort<My::TimedPose>& in_ = add_in_port<My::TimedPose>("in0");
  rtm::OutPort<My::TimedPose>& out_ = add_out_port<My::TimedPose>("out0");
};

}  // namespace

int main(int argc, char** argv) {
  return rtm::run_component(argc, argv, {
      .kind = "pose-relay",
      .description = "writes a TimedPose ramp on out0, reads TimedPose on in0",
      .create = [](const rtm::RunSettings& settings) { return std::make_unique<PoseRelay>(settings.name); },
  });
}
