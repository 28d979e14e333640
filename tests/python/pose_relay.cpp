// SPDX-License-Identifier: Apache-2.0
// rtm-test-pose-relay: a component whose ports carry a type of a project's own IDL
// (RtmTest::TimedPose, tests/support/test_types.idl): each cycle a new pose came to pose_in,
// pose_out writes it. The Python package's tests get and put it by its fields: `import rtm` has
// no code for the type, only its TypeCode.
#include "host/runner.h"
#include "rtm/component.h"
#include "rtm/data.h"
#include "rtm/describe.h"

#include "test_types.hh"

RTM_DATA_TYPE(RtmTest, TimedPose);

#include <memory>
#include <string>

namespace {

std::vector<rtm::Element> pose_elements() { return rtm::elements("x y z qw qx qy qz", "m m m - - - -"); }

class PoseRelay final : public rtm::Component {
 public:
  explicit PoseRelay(std::string name) : Component(std::move(name), "pose_relay") {}
  void on_cycle(const rtm::CycleContext&) override {
    if (in_.read(pose_) == rtm::ReadResult::NewData) out_.write(pose_);
  }

 private:
  rtm::InPort<RtmTest::TimedPose>& in_ = add_in_port<RtmTest::TimedPose>("pose_in", {"a pose", pose_elements()});
  rtm::OutPort<RtmTest::TimedPose>& out_ =
      add_out_port<RtmTest::TimedPose>("pose_out", {"the pose it was given", pose_elements()});
  RtmTest::TimedPose pose_{};
};

}  // namespace

int main(int argc, char** argv) {
  return rtm::run_component(argc, argv,
                            {.kind = "pose_relay",
                             .description = "passes on the poses it is given (a type of a project's own IDL)",
                             .create = [](const rtm::RunSettings& s) -> std::unique_ptr<rtm::Component> {
                               return std::make_unique<PoseRelay>(s.name);
                             }});
}
