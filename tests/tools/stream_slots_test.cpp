// SPDX-License-Identifier: Apache-2.0
// rtm serve's stream slots: a cap on all streams together, one of each kind per page, a page's
// new stream replacing its old one, and a slot freed when its stream ends.
#include "serve/stream_slots.h"

#include "serve/plot_feed.h"

#include <nlohmann/json.hpp>

#include <cmath>

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

// What the plots' stream sends of one port (serve/plot_feed.h): every datum, as columns.
namespace plot_entry {

using rtm::cli::plot_entry;
using rtm::cli::Sample;

TEST(PlotEntry, EveryDatumIsSentAsAStampAndOneColumnPerValueWithTheCounts) {
  const std::vector<Sample> samples{{"RTM::TimedFloat3", 1'795'445'401'000'000'000LL, {1.0, 2.0, 3.0}},
                                    {"RTM::TimedFloat3", 1'795'445'401'002'000'001LL, {-1.5, 0.25, 1e-3}}};
  const auto j = nlohmann::json::parse(plot_entry("RTM::TimedFloat3", samples, 42, 3, 0));
  EXPECT_EQ(j["type"], "RTM::TimedFloat3");
  ASSERT_EQ(j["t"].size(), 2u);
  EXPECT_DOUBLE_EQ(j["t"][1].get<double>(), 1795445401.002000001);
  ASSERT_EQ(j["v"].size(), 3u) << "one column per value";
  EXPECT_EQ(j["v"][0], (nlohmann::json{1.0, -1.5}));
  EXPECT_EQ(j["v"][2], (nlohmann::json{3.0, 0.001}));
  EXPECT_EQ(j["sent"], 42);
  EXPECT_EQ(j["lost"], 3);
  EXPECT_EQ(j["stamped"], true);
  EXPECT_EQ(j["time"]["nsec"], 2'000'001) << "the last datum's stamp, as /api/values gives it";
  EXPECT_EQ(j["values"], (nlohmann::json{-1.5, 0.25, 0.001}));
}

TEST(PlotEntry, NoDataIsEmptyColumnsAndAnUnstampedDatumTakesWhenTheServerTookItAndNoNumberIsNull) {
  const auto none = nlohmann::json::parse(plot_entry("RTM::TimedFloat", {}, 7, 0, 5));
  EXPECT_TRUE(none["t"].empty());
  EXPECT_TRUE(none["v"].empty());
  EXPECT_EQ(none["sent"], 7);
  EXPECT_FALSE(none.contains("time"));
  const std::vector<Sample> unstamped{{"My::Pose", 0, {std::nan(""), 2.0}}};
  const auto j = nlohmann::json::parse(plot_entry("My::Pose", unstamped, 1, 0, 3'000'000'123LL));
  EXPECT_EQ(j["stamped"], false);
  EXPECT_EQ(j["t"][0].dump(), "3.000000123");
  EXPECT_TRUE(j["v"][0][0].is_null()) << "NaN is no JSON number";
}

}  // namespace plot_entry
