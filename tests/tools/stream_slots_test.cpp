// SPDX-License-Identifier: Apache-2.0
// rtm serve's stream slots: a cap on all streams together, one of each kind per page, a page's
// new stream replacing its old one, and a slot freed when its stream ends.
#include "serve/stream_slots.h"

#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

namespace {

using rtm::cli::StreamSlots;
using rtm::cli::StreamsFull;
using Kind = StreamSlots::Kind;

TEST(StreamSlots, BeyondTheCapAStreamIsRefusedWithASentenceAndAnEndedOneFreesItsSlot) {
  StreamSlots slots(3);
  std::vector<std::shared_ptr<StreamSlots::Slot>> open;
  for (int i = 0; i < 3; ++i) open.push_back(slots.open("", Kind::system));
  EXPECT_EQ(slots.open_count(), 3u);
  try {
    slots.open("", Kind::system);
    FAIL() << "a fourth stream was let in";
  } catch (const StreamsFull& e) {
    EXPECT_NE(std::string(e.what()).find("3 streams are open"), std::string::npos) << e.what();
  }
  EXPECT_THROW(slots.open("pageA", Kind::values), StreamsFull) << "a page's first stream counts like any other";
  open.pop_back();
  EXPECT_EQ(slots.open_count(), 2u);
  EXPECT_NO_THROW(open.push_back(slots.open("pageA", Kind::values)));
}

TEST(StreamSlots, APagesNewStreamOfAKindReplacesItsOldOneEvenWhenAllSlotsAreTaken) {
  StreamSlots slots(2);
  auto events = slots.open("pageA", Kind::system);
  auto plots = slots.open("pageA", Kind::values);
  EXPECT_EQ(slots.open_count(), 2u);
  auto again = slots.open("pageA", Kind::system);  // the page came back: its old stream ends
  EXPECT_TRUE(events->replaced());
  EXPECT_FALSE(plots->replaced()) << "a stream of the other kind stays";
  EXPECT_FALSE(again->replaced());
  EXPECT_EQ(slots.open_count(), 2u);
  events.reset();  // the replaced stream ends: its place had passed on already
  EXPECT_EQ(slots.open_count(), 2u);
  EXPECT_THROW(slots.open("pageB", Kind::system), StreamsFull);
  again.reset();
  EXPECT_EQ(slots.open_count(), 1u);
  EXPECT_NO_THROW(slots.open("pageB", Kind::system));
}

TEST(StreamSlots, StreamsThatNameNoPageNeverReplaceEachOther) {
  StreamSlots slots(4);
  auto a = slots.open("", Kind::system), b = slots.open("", Kind::system);
  EXPECT_FALSE(a->replaced());
  EXPECT_FALSE(b->replaced());
  EXPECT_EQ(slots.open_count(), 2u);
}

TEST(StreamSlots, APageIdOutsideTheRuleIsRefused) {
  StreamSlots slots(4);
  EXPECT_THROW(slots.open("<img src=x>", Kind::system), std::invalid_argument);
  EXPECT_THROW(slots.open(std::string(65, 'a'), Kind::system), std::invalid_argument);
  EXPECT_NO_THROW(slots.open("0123456789abcdef_-AZ", Kind::system));
}

TEST(StreamSlots, ASlotOutlivingItsSlotsIsFreedSafely) {
  std::shared_ptr<StreamSlots::Slot> kept;
  {
    StreamSlots slots(1);
    kept = slots.open("pageA", Kind::system);
  }
  EXPECT_FALSE(kept->replaced());
  kept.reset();
}

}  // namespace
