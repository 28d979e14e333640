// SPDX-License-Identifier: Apache-2.0
// rtm::Freshness: the age of an input's newest datum, and the one cycle it goes stale.
#include "rtm/freshness.h"

#include <gtest/gtest.h>

namespace rtm {
namespace {

using Change = Freshness::Change;

TEST(Freshness, NothingSeenIsNotFreshAndNeverGoesStale) {
  Freshness f(3);
  EXPECT_FALSE(f.fresh());
  for (int i = 0; i < 10; ++i) EXPECT_EQ(f.tick(false), Change::none);
  EXPECT_FALSE(f.fresh());
  EXPECT_FALSE(f.seen());
}

TEST(Freshness, ADatumIsFreshForLimitCyclesThenGoesStaleOnce) {
  Freshness f(3);
  EXPECT_EQ(f.tick(true), Change::none);
  EXPECT_TRUE(f.fresh());
  EXPECT_EQ(f.tick(false), Change::none);  // age 1
  EXPECT_EQ(f.tick(false), Change::none);  // age 2
  EXPECT_TRUE(f.fresh());
  EXPECT_EQ(f.tick(false), Change::went_stale);  // age 3 = limit
  EXPECT_FALSE(f.fresh());
  for (int i = 0; i < 10; ++i) EXPECT_EQ(f.tick(false), Change::none) << "reported again at cycle " << i;
  EXPECT_EQ(f.age(), 3u);  // saturates at the limit
}

TEST(Freshness, NewDataKeepsItFreshAndAStaleInputRecoversOnTheNextDatum) {
  Freshness f(2);
  for (int i = 0; i < 20; ++i) {
    EXPECT_EQ(f.tick(i % 2 == 0), Change::none) << i;  // a datum every other cycle: age 0, 1, 0, 1, ...
    EXPECT_TRUE(f.fresh()) << i;
  }
  f.tick(false);
  EXPECT_FALSE(f.fresh());
  EXPECT_EQ(f.tick(true), Change::none);
  EXPECT_TRUE(f.fresh());
  f.tick(false);
  EXPECT_EQ(f.tick(false), Change::went_stale);  // a second event
}

TEST(Freshness, ALimitOfOneGoesStaleOnTheFirstCycleWithoutADatum) {
  Freshness f(1);
  f.tick(true);
  EXPECT_TRUE(f.fresh());
  EXPECT_EQ(f.tick(false), Change::went_stale);
}

TEST(Freshness, ResetForgetsTheDatum) {
  Freshness f(3);
  f.tick(true);
  f.reset();
  EXPECT_FALSE(f.fresh());
  EXPECT_FALSE(f.seen());
  EXPECT_EQ(f.tick(false), Change::none);  // nothing seen: no stale event
}

}  // namespace
}  // namespace rtm
