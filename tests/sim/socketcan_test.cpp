// pa10-sim and the arm library over real SocketCAN: the whole check (sim_vcan_check) runs
// inside User-Mode Linux with vcan0, through the project's runner script.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <string>

#include "rtm_test/child_process.h"

using namespace std::chrono_literals;

TEST(Pa10SimOverSocketCan, ArmMovesOverVcan0InUmlAndCandumpSeesSyncAndPdoTraffic) {
  const std::string runner = std::string(RTM_SOURCE_DIR_PATH) + "/tests/can/uml-vcan-run.sh";
  ASSERT_TRUE(std::filesystem::exists(runner)) << runner << " is missing";
  rtm_test::ChildProcess::Options options;
  options.stop_grace = 10s;
  rtm_test::ChildProcess uml({runner, "-m", "512M", "--", VCAN_CHECK_EXE, PA10_SIM_EXE, RTM_PA10_URDF},
                             options);
  const auto status = uml.wait_for_exit(std::chrono::minutes(4));
  ASSERT_TRUE(status.has_value()) << "UML run did not finish:\n" << uml.output();
  if (status->exited && status->code == 2 &&
      uml.output().find("install Debian's user-mode-linux") != std::string::npos)
    GTEST_SKIP() << "user-mode-linux is not installed";
  EXPECT_TRUE(status->clean()) << status->to_string() << "\n" << uml.output();
  EXPECT_NE(uml.output().find("vcan check passed"), std::string::npos) << uml.output();
}
