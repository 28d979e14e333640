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
