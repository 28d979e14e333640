// rtm's value conversions: what `rtm put` builds from words and `rtm get` prints.
#include "values.h"

#include "rtm/data.h"

#include <gtest/gtest.h>

namespace {

using rtm::cli::ValueError;
using Words = std::vector<std::string>;

TEST(RtmValues, PutWordsBuildATimedFloat6StampedNow) {
  const auto before = rtm::to_ns(rtm::now());
  CORBA::Any any = rtm::cli::parse_value(RTM::_tc_TimedFloat6, Words{"1", "-2.5", "3", "0", "0", "6e1"});
  const RTM::TimedFloat6* d = nullptr;
  ASSERT_TRUE(any >>= d);
  EXPECT_FLOAT_EQ(d->val[0], 1.0f);
  EXPECT_FLOAT_EQ(d->val[1], -2.5f);
  EXPECT_FLOAT_EQ(d->val[5], 60.0f);
  EXPECT_GE(rtm::to_ns(d->tm), before);
}

TEST(RtmValues, WrongValueCountIsRefusedNamingTypeAndCounts) {
  try {
    rtm::cli::parse_value(RTM::_tc_TimedFloat6, Words{"1", "2"});
    FAIL() << "expected ValueError";
  } catch (const ValueError& e) {
    EXPECT_STREQ(e.what(), "RTM::TimedFloat6 takes 6 values, got 2");
  }
}

TEST(RtmValues, NonNumberWordIsRefusedNamingTheWord) {
  try {
    rtm::cli::parse_value(RTM::_tc_TimedFloat, Words{"fast"});
    FAIL() << "expected ValueError";
  } catch (const ValueError& e) {
    EXPECT_STREQ(e.what(), "'fast' is not a number");
  }
}

TEST(RtmValues, NaNAndInfinityAreRefused) {
  EXPECT_THROW(rtm::cli::parse_value(RTM::_tc_TimedDouble, Words{"nan"}), ValueError);
  EXPECT_THROW(rtm::cli::parse_value(RTM::_tc_TimedDouble, Words{"inf"}), ValueError);
}

TEST(RtmValues, LongRefusesFractionsAndOutOfRange) {
  EXPECT_THROW(rtm::cli::parse_value(RTM::_tc_TimedLong, Words{"1.5"}), ValueError);
  EXPECT_THROW(rtm::cli::parse_value(RTM::_tc_TimedLong, Words{"3000000000"}), ValueError);
  CORBA::Any any = rtm::cli::parse_value(RTM::_tc_TimedLong, Words{"-42"});
  const RTM::TimedLong* d = nullptr;
  ASSERT_TRUE(any >>= d);
  EXPECT_EQ(d->data, -42);
}

TEST(RtmValues, SequencesTakeAnyCount) {
  CORBA::Any any = rtm::cli::parse_value(RTM::_tc_TimedDoubleSeq, Words{"1", "2", "3", "4"});
  const RTM::TimedDoubleSeq* d = nullptr;
  ASSERT_TRUE(any >>= d);
  ASSERT_EQ(d->data.length(), 4u);
  EXPECT_DOUBLE_EQ(d->data[3], 4.0);
}

TEST(RtmValues, UnknownTypeCannotBeBuilt) {
  EXPECT_THROW(rtm::cli::parse_value(CORBA::_tc_string, Words{"x"}), ValueError);
}

TEST(RtmValues, TextShowsUtcTimeAndValuesWithUnits) {
  RTM::TimedFloat6 d;
  d.tm.sec = 0;
  d.tm.nsec = 5;
  for (int i = 0; i < 6; ++i) d.val[i] = static_cast<float>(i);
  CORBA::Any any;
  any <<= d;
  EXPECT_EQ(rtm::cli::format_text(any, {"N", "N", "N", "N·m", "N·m", "N·m"}),
            "1970-01-01T00:00:00.000000005Z  0.0000 N  1.0000 N  2.0000 N  3.0000 N·m  "
            "4.0000 N·m  5.0000 N·m");
}

TEST(RtmValues, JsonCarriesTypeTimeAndValues) {
  RTM::TimedFloat3 d;
  d.tm.sec = 7;
  d.tm.nsec = 8;
  d.val[0] = 1;
  d.val[1] = 2;
  d.val[2] = 3;
  CORBA::Any any;
  any <<= d;
  auto j = rtm::cli::format_json(any);
  EXPECT_EQ(j["type"], "RTM::TimedFloat3");
  EXPECT_EQ(j["time"]["sec"], 7);
  EXPECT_EQ(j["values"].size(), 3u);
  EXPECT_EQ(j["values"][2], 3.0);
}

TEST(RtmValues, MissingUnitsLeaveTheValuesBare) {
  RTM::TimedFloat3 d{};
  d.val[0] = 1;
  CORBA::Any any;
  any <<= d;
  EXPECT_EQ(rtm::cli::format_text(any, {"m", ""}), "1970-01-01T00:00:00.000000000Z  1.0000 m  0.0000  0.0000");
}

TEST(RtmValues, UnknownTypePrintsItsNameNotGarbage) {
  CORBA::Any any;
  any <<= CORBA::Long(5);
  EXPECT_EQ(rtm::cli::format_text(any), "<long>");
}

}  // namespace
