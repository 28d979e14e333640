// SPDX-License-Identifier: Apache-2.0
// The one place a force sensor's two TPDOs become a wrench, and the drives' TPDOs a joint state
// (the master's cycle and the passive listeners use them).
#include "arm/can/joint_assembly.h"
#include "arm/can/wrench_assembly.h"

#include <gtest/gtest.h>

namespace rtm::can {
namespace {

TEST(WrenchAssembly, BothHalvesInEitherOrderMakeTheWrench) {
  WrenchAssembly a;
  EXPECT_FALSE(a.complete());
  EXPECT_FALSE(a.add_torque({4, 5, 6}));
  EXPECT_FALSE(a.complete()) << "torque alone is half a wrench";
  EXPECT_FALSE(a.add_force({1, 2, 3}));
  ASSERT_TRUE(a.complete());
  EXPECT_EQ(a.values(), (std::array<double, 6>{1, 2, 3, 4, 5, 6}));
}

// A late answer or a spoofer beside the genuine one: which is genuine is unknown.
TEST(WrenchAssembly, AHalfArrivingTwiceIsReportedAndTheWrenchOfThatSyncIsWithheld) {
  WrenchAssembly a;
  EXPECT_FALSE(a.add_force({1, 1, 1}));
  EXPECT_TRUE(a.add_force({2, 2, 2}));
  a.add_torque({0, 0, 0});
  EXPECT_TRUE(a.answered()) << "both halves came: nothing more to wait for";
  EXPECT_FALSE(a.complete()) << "but neither force can be trusted";
  EXPECT_EQ(a.values()[0], 1.0) << "the second value is not taken either";
  a.restart();
  a.add_force({3, 3, 3});
  a.add_torque({0, 0, 0});
  EXPECT_TRUE(a.complete()) << "the next SYNC starts trusted again";
  EXPECT_EQ(a.values()[0], 3.0);
}

TEST(WrenchAssembly, ANewSyncReportsAnOrphanHalfAndStartsEmpty) {
  WrenchAssembly a;
  EXPECT_FALSE(a.restart()) << "nothing gathered: nothing lost";
  a.add_force({1, 2, 3});
  EXPECT_TRUE(a.restart()) << "the force's torque never came";
  EXPECT_FALSE(a.complete());
  a.add_torque({4, 5, 6});
  EXPECT_FALSE(a.complete()) << "the force of the previous SYNC does not count";
  a.add_force({7, 8, 9});
  EXPECT_TRUE(a.complete());
  EXPECT_FALSE(a.restart()) << "a complete wrench is no orphan";
}


TEST(JointAssembly, ADriveAnsweringTwiceIsWithheldAndTheStateSaysIncomplete) {
  JointAssembly a;
  JointState state{};
  for (int j = 0; j < kDriveCount; ++j) a.add({drive_node(j), 0x0027, 0.1 * j, 0.0});
  a.fill(state);
  EXPECT_TRUE(state.complete);
  a.restart();
  for (int j = 0; j < kDriveCount; ++j) a.add({drive_node(j), 0x0027, 1.0 + j, 0.0});
  EXPECT_TRUE(a.add({drive_node(2), 0x0027, -9.0, 0.0})) << "drive 3 answered this SYNC already";
  EXPECT_TRUE(a.complete()) << "every drive answered: nothing more to wait for";
  EXPECT_FALSE(a.trusted(2));
  EXPECT_TRUE(a.trusted(1));
  a.fill(state);
  EXPECT_FALSE(state.complete);
  EXPECT_EQ(state.position_rad[1], 2.0);
  EXPECT_EQ(state.position_rad[2], 0.2) << "drive 3 keeps the last value it was trusted with";
}

}  // namespace
}  // namespace rtm::can
