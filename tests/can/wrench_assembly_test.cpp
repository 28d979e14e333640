// SPDX-License-Identifier: Apache-2.0
// The one place a force sensor's two TPDOs become a wrench (the master's cycle and the passive
// listener both use it).
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

TEST(WrenchAssembly, AHalfArrivingTwiceIsReportedAndTheNewerValueKept) {
  WrenchAssembly a;
  a.add_force({1, 1, 1});
  EXPECT_TRUE(a.add_force({2, 2, 2}));
  a.add_torque({0, 0, 0});
  EXPECT_EQ(a.values()[0], 2.0);
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

}  // namespace
}  // namespace rtm::can
