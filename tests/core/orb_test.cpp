// SPDX-License-Identifier: Apache-2.0
#include "rtm/component.h"
#include "rtm/orb.h"

#include <gtest/gtest.h>
#include <pwd.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <filesystem>
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

// A unix socket at path, as omniORB leaves one behind.
void make_socket_file(const std::string& path) {
  const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
  ASSERT_GE(fd, 0);
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  std::snprintf(address.sun_path, sizeof address.sun_path, "%s", path.c_str());
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address), 0) << path;
  ::close(fd);  // the file stays, as after a SIGKILL
}

TEST(Orb, UnixSocketsLeftByProcessesThatNoLongerExistAreRemovedAtStartAndLiveOnesKept) {
  const std::string folder = "/tmp/omni-" + std::string(::getpwuid(::geteuid())->pw_name);
  std::filesystem::create_directories(folder);
  pid_t dead = 4'000'000;
  while (dead > 1000 && !(::kill(dead, 0) != 0 && errno == ESRCH)) --dead;
  char name[64];
  std::snprintf(name, sizeof name, "%s/%09d-1", folder.c_str(), static_cast<int>(dead));
  const std::string stale = name;
  std::snprintf(name, sizeof name, "%s/%09d-999", folder.c_str(), static_cast<int>(::getpid()));
  const std::string live = name;
  std::filesystem::remove(stale);
  std::filesystem::remove(live);
  make_socket_file(stale);
  make_socket_file(live);
  {
    rtm::Orb orb;
  }
  EXPECT_FALSE(std::filesystem::exists(stale)) << stale;
  EXPECT_TRUE(std::filesystem::exists(live)) << live;
  std::filesystem::remove(live);
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
