// SPDX-License-Identifier: Apache-2.0
// SenderOrder: the per-sender order check behind RTM::InPortOrdered.
#include "rtm/sender_order.h"

#include <gtest/gtest.h>

namespace {

TEST(SenderOrder, TakesRisingNumbersAndRefusesARepeatOrAnOlderOneOfTheSameSender) {
  rtm::SenderOrder order;
  EXPECT_TRUE(order.admit(7, 1));
  EXPECT_TRUE(order.admit(7, 3));   // a gap (data dropped at the sender) is fine
  EXPECT_FALSE(order.admit(7, 2)) << "arrived after datum 3: late";
  EXPECT_FALSE(order.admit(7, 3)) << "the same datum twice";
  EXPECT_TRUE(order.admit(7, 4)) << "a late datum does not move the mark";
}

TEST(SenderOrder, KeepsEachSendersOrderApart) {
  rtm::SenderOrder order;
  EXPECT_TRUE(order.admit(1, 10));
  EXPECT_TRUE(order.admit(2, 1)) << "another sender's low number is not late";
  EXPECT_FALSE(order.admit(1, 9));
  EXPECT_TRUE(order.admit(2, 2));
}

TEST(SenderOrder, ANewSenderBeyondTheSlotsTakesTheOneHeardFromLongestAgo) {
  rtm::SenderOrder order;
  for (std::uint64_t sender = 1; sender <= rtm::SenderOrder::kSenders; ++sender) ASSERT_TRUE(order.admit(sender, 5));
  EXPECT_TRUE(order.admit(1, 6));  // sender 1 is now the most recent; 2 the oldest
  EXPECT_TRUE(order.admit(100, 1));  // takes sender 2's slot
  EXPECT_FALSE(order.admit(1, 5)) << "sender 1 was kept";
  EXPECT_FALSE(order.admit(3, 5)) << "sender 3 was kept";
  EXPECT_TRUE(order.admit(2, 1)) << "sender 2 was forgotten: a new start for it";
}

}  // namespace
