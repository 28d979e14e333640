#include "rtm/component.h"
#include "rtm/orb.h"

#include <gtest/gtest.h>

#include <thread>

namespace {

TEST(Orb, RunReturnsAfterShutdownFromAnotherThreadAndInstanceTracksTheLiveOrb) {
  EXPECT_EQ(rtm::Orb::instance(), nullptr);
  {
    rtm::Orb orb({"-ORBendPoint", "giop:tcp:127.0.0.1:"});
    EXPECT_EQ(rtm::Orb::instance(), &orb);
    EXPECT_FALSE(CORBA::is_nil(orb.poa()));
    std::thread stopper([&orb] {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      orb.shutdown();
      orb.shutdown();  // idempotent
    });
    orb.run();
    stopper.join();
  }
  EXPECT_EQ(rtm::Orb::instance(), nullptr);
}

TEST(Orb, ServantsMayOutliveTheOrb) {
  class Idle final : public rtm::Component {
   public:
    Idle() : Component("idle0", "test") { add_in_port<RTM::TimedFloat6>("in0"); }
    void on_cycle(const rtm::CycleContext&) override {}
  };
  auto servant = std::make_unique<rtm::ComponentServant>(std::make_unique<Idle>(), rtm::ExternalTick{});
  {
    rtm::Orb orb;
    RTM::RtComponentEx_var ref = servant->activate(orb);
    EXPECT_EQ(servant->component().in_ports()[0]->active(), true);
  }
  servant.reset();  // deactivation after the ORB is gone: nothing to do, nothing to crash
}

TEST(Orb, FromStringRefusesTextThatIsNoReference) {
  rtm::Orb orb;
  try {
    orb.from_string("not-a-reference");
    FAIL() << "from_string accepted garbage";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("not-a-reference"), std::string::npos) << e.what();
  }
}

TEST(Orb, AnUnusableEndpointIsAClearError) {
  try {
    rtm::Orb orb({"-ORBendPoint", "giop:nosuchtransport:xyz"});
    FAIL() << "an ORB with an impossible endpoint was created";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("ORB initialisation failed"), std::string::npos) << e.what();
  }
}

}  // namespace
