// SPDX-License-Identifier: Apache-2.0
// rtm's value conversions: what `rtm put` builds from words and `rtm get` prints.
#include "browser/values.h"

#include "rtm/data.h"
#include "rtm/orb.h"
#include "test_types.hh"

#include <gtest/gtest.h>

#include <memory>

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

// ============ types of a project's own IDL, read and built from their TypeCode ============

// A DynAny needs the process's ORB.
class RtmValuesOfAnyStruct : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { orb_ = std::make_unique<rtm::Orb>(); }
  static void TearDownTestSuite() { orb_.reset(); }

  static std::string error_of(CORBA::TypeCode_ptr type, const Words& words) {
    try {
      rtm::cli::parse_value(type, words);
    } catch (const ValueError& e) {
      return e.what();
    }
    return "no error";
  }

 private:
  static std::unique_ptr<rtm::Orb> orb_;
};
std::unique_ptr<rtm::Orb> RtmValuesOfAnyStruct::orb_;

RtmTest::TimedPose pose_at_epoch() {
  RtmTest::TimedPose d{};
  d.tm.sec = 0;
  d.tm.nsec = 5;
  d.p.x = 0.001;
  d.p.y = 0.5;
  d.p.z = -2;
  d.q[0] = 1;
  return d;
}

TEST_F(RtmValuesOfAnyStruct, PutWordsFillNestedMembersAndArraysInOrderStampedNow) {
  const auto before = rtm::to_ns(rtm::now());
  CORBA::Any any = rtm::cli::parse_value(RtmTest::_tc_TimedPose, Words{"0.001", "0.5", "-2", "1", "0", "0", "0.25"});
  const RtmTest::TimedPose* d = nullptr;
  ASSERT_TRUE(any >>= d);
  EXPECT_DOUBLE_EQ(d->p.x, 0.001);
  EXPECT_DOUBLE_EQ(d->p.y, 0.5);
  EXPECT_DOUBLE_EQ(d->p.z, -2.0);
  EXPECT_DOUBLE_EQ(d->q[0], 1.0);
  EXPECT_DOUBLE_EQ(d->q[3], 0.25);
  EXPECT_GE(rtm::to_ns(d->tm), before);
}

TEST_F(RtmValuesOfAnyStruct, ValueBuiltFromTheTypeCodeAloneReadsBackAsJson) {
  CORBA::Any any = rtm::cli::parse_value(RtmTest::_tc_TimedPose, Words{"0.001", "0.5", "-2", "1", "0", "0", "0.25"});
  auto j = rtm::cli::format_json(any);
  EXPECT_EQ(j["type"], "RtmTest::TimedPose");
  EXPECT_GT(j["time"]["sec"].get<unsigned long>(), 0u);
  EXPECT_EQ(j["values"], (nlohmann::json{0.001, 0.5, -2.0, 1.0, 0.0, 0.0, 0.25}));
  EXPECT_EQ(j["fields"]["p"]["y"], 0.5);
  EXPECT_EQ(j["fields"]["q"], (nlohmann::json{1.0, 0.0, 0.0, 0.25}));
  EXPECT_FALSE(j["fields"].contains("tm"));
}

TEST_F(RtmValuesOfAnyStruct, TextShowsStampThenMemberPathsWithArraysInBrackets) {
  CORBA::Any any;
  any <<= pose_at_epoch();
  EXPECT_EQ(rtm::cli::format_text(any),
            "1970-01-01T00:00:00.000000005Z  p.x=0.0010  p.y=0.5000  p.z=-2.0000  "
            "q=[1.0000 0.0000 0.0000 0.0000]");
}

TEST_F(RtmValuesOfAnyStruct, UnitsFollowEachNumberInOrder) {
  CORBA::Any any;
  any <<= pose_at_epoch();
  EXPECT_EQ(rtm::cli::format_text(any, {"m", "m", "", "", "rad"}),
            "1970-01-01T00:00:00.000000005Z  p.x=0.0010 m  p.y=0.5000 m  p.z=-2.0000  "
            "q=[1.0000 0.0000 rad 0.0000 0.0000]");
}

TEST_F(RtmValuesOfAnyStruct, ThePortsElementNamesLabelEveryNumberWhenThereIsOneForEach) {
  CORBA::Any any;
  any <<= pose_at_epoch();
  const std::vector<std::string> names = {"x", "y", "z", "qw", "qx", "qy", "qz"};
  EXPECT_EQ(rtm::cli::format_text(any, {"m", "m", "m"}, names),
            "1970-01-01T00:00:00.000000005Z  x=0.0010 m  y=0.5000 m  z=-2.0000 m  qw=1.0000  qx=0.0000  qy=0.0000  "
            "qz=0.0000");
  EXPECT_EQ(rtm::cli::value_labels(any, names), names) << "the CSV's columns are the same labels";
  // Not one name per number: the leaf paths, in the text and in the CSV alike.
  const std::vector<std::string> short_names = {"x", "y", "z"};
  EXPECT_EQ(rtm::cli::format_text(any, {}, short_names), rtm::cli::format_text(any));
  EXPECT_EQ(rtm::cli::value_labels(any, short_names),
            (std::vector<std::string>{"p.x", "p.y", "p.z", "q[0]", "q[1]", "q[2]", "q[3]"}));
}

TEST(RtmValueLabels, ABuiltInTypeIsLabelledByItsElementNamesElseByPosition) {
  CORBA::Any any;
  RTM::TimedFloat3 d{};
  any <<= d;
  EXPECT_EQ(rtm::cli::value_labels(any), (std::vector<std::string>{"v0", "v1", "v2"}));
  EXPECT_EQ(rtm::cli::value_labels(any, {"vx", "vy", "vz"}), (std::vector<std::string>{"vx", "vy", "vz"}));
  EXPECT_EQ(rtm::cli::value_labels(any, {"vx"}), (std::vector<std::string>{"v0", "v1", "v2"}));
}

TEST_F(RtmValuesOfAnyStruct, SampleCarriesStampAndFlattenedNumbers) {
  CORBA::Any any;
  any <<= pose_at_epoch();
  const auto s = rtm::cli::to_sample(any);
  EXPECT_EQ(s.type, "RtmTest::TimedPose");
  EXPECT_EQ(s.time_ns, 5);
  EXPECT_EQ(s.values, (std::vector<double>{0.001, 0.5, -2.0, 1.0, 0.0, 0.0, 0.0}));
}

TEST_F(RtmValuesOfAnyStruct, BooleansEnumsAndATrailingSequenceRoundTrip) {
  CORBA::Any any = rtm::cli::parse_value(RtmTest::_tc_TimedMixed, Words{"-7", "true", "RUN", "0.5", "1.5", "2.5"});
  const RtmTest::TimedMixed* d = nullptr;
  ASSERT_TRUE(any >>= d);
  EXPECT_EQ(d->n, -7);
  EXPECT_TRUE(d->on);
  EXPECT_EQ(d->mode, RtmTest::RUN);
  ASSERT_EQ(d->data.length(), 3u);
  EXPECT_FLOAT_EQ(d->data[2], 2.5f);

  const std::string text = rtm::cli::format_text(any);
  EXPECT_NE(text.find("Z  n=-7  on=true  mode=RUN  data=[0.5000 1.5000 2.5000]"), std::string::npos) << text;
  auto j = rtm::cli::format_json(any);
  EXPECT_EQ(j["values"], (nlohmann::json{-7.0, 1.0, 1.0, 0.5, 1.5, 2.5}));
  EXPECT_EQ(j["fields"]["on"], true);
  EXPECT_EQ(j["fields"]["mode"], "RUN");
  EXPECT_EQ(rtm::cli::to_sample(any).values, (std::vector<double>{-7, 1, 1, 0.5, 1.5, 2.5}));
}

TEST_F(RtmValuesOfAnyStruct, EnumByIndexBooleanAsDigitAndEmptyTrailingSequence) {
  CORBA::Any any = rtm::cli::parse_value(RtmTest::_tc_TimedMixed, Words{"3", "0", "1"});
  const RtmTest::TimedMixed* d = nullptr;
  ASSERT_TRUE(any >>= d);
  EXPECT_FALSE(d->on);
  EXPECT_EQ(d->mode, RtmTest::RUN);
  EXPECT_EQ(d->data.length(), 0u);
}

TEST_F(RtmValuesOfAnyStruct, EveryBasicKindAndAStringRoundTripAtTheirLimits) {
  CORBA::Any any = rtm::cli::parse_value(
      RtmTest::_tc_TimedScalars, Words{"-32768", "65535", "4294967295", "-9223372036854775808",
                                       "18446744073709551615", "255", "A", "1e3", "left-arm"});
  const RtmTest::TimedScalars* d = nullptr;
  ASSERT_TRUE(any >>= d);
  EXPECT_EQ(d->s, -32768);
  EXPECT_EQ(d->us, 65535);
  EXPECT_EQ(d->ul, 4294967295u);
  EXPECT_EQ(d->ll, std::numeric_limits<CORBA::LongLong>::min());
  EXPECT_EQ(d->ull, std::numeric_limits<CORBA::ULongLong>::max());
  EXPECT_EQ(d->o, 255);
  EXPECT_EQ(d->c, 'A');
  EXPECT_FLOAT_EQ(d->f, 1000.0f);
  EXPECT_STREQ(d->label.in(), "left-arm");

  const std::string text = rtm::cli::format_text(any);
  EXPECT_NE(text.find("c=65  f=1000.0000  label=left-arm"), std::string::npos) << text;
  auto j = rtm::cli::format_json(any);
  EXPECT_EQ(j["fields"]["label"], "left-arm");
  EXPECT_EQ(j["fields"]["ull"], std::numeric_limits<CORBA::ULongLong>::max());
  EXPECT_EQ(j["values"].size(), 8u) << "the string is no value";
  EXPECT_EQ(rtm::cli::to_sample(any).values.size(), 8u);
}

TEST_F(RtmValuesOfAnyStruct, SequenceOfStructsTakesWholeElements) {
  CORBA::Any any = rtm::cli::parse_value(RtmTest::_tc_TimedPath, Words{"1", "2", "3", "4", "5", "6"});
  const RtmTest::TimedPath* d = nullptr;
  ASSERT_TRUE(any >>= d);
  ASSERT_EQ(d->points.length(), 2u);
  EXPECT_DOUBLE_EQ(d->points[1].x, 4.0);
  EXPECT_NE(rtm::cli::format_text(any).find("points[1].x=4.0000  points[1].y=5.0000"), std::string::npos);
  EXPECT_EQ(error_of(RtmTest::_tc_TimedPath, Words{"1", "2", "3", "4"}),
            "RtmTest::TimedPath takes 0 values and then 3 per element of points, got 4");
}

TEST_F(RtmValuesOfAnyStruct, StructWithoutTimeTakesEveryMemberAndHasNoStamp) {
  CORBA::Any any = rtm::cli::parse_value(RtmTest::_tc_Plain, Words{"1.5", "2"});
  EXPECT_EQ(rtm::cli::format_text(any), "a=1.5000  b=2");
  EXPECT_FALSE(rtm::cli::format_json(any).contains("time"));
  EXPECT_EQ(rtm::cli::to_sample(any).time_ns, 0);
}

TEST_F(RtmValuesOfAnyStruct, WrongCountIsRefusedListingTheMembers) {
  EXPECT_EQ(error_of(RtmTest::_tc_TimedPose, Words{"1", "2", "3", "4", "5"}),
            "RtmTest::TimedPose takes 7 values (p.x p.y p.z q[0] q[1] q[2] q[3]), got 5");
  EXPECT_EQ(error_of(RtmTest::_tc_TimedMixed, Words{"1", "true"}),
            "RtmTest::TimedMixed takes 3 values (n on mode) and then any number for data, got 2");
}

TEST_F(RtmValuesOfAnyStruct, BadNumberIsRefusedNamingMemberPathAndWord) {
  EXPECT_EQ(error_of(RtmTest::_tc_TimedPose, Words{"1", "abc", "3", "4", "5", "6", "7"}), "p.y: 'abc' is not a number");
  EXPECT_EQ(error_of(RtmTest::_tc_TimedPose, Words{"1", "2", "3", "4", "5", "nan", "7"}),
            "q[2]: 'nan' is not a finite number");
  EXPECT_EQ(error_of(RtmTest::_tc_TimedMixed, Words{"1.5", "true", "RUN"}), "n: '1.5' is not a whole number");
  EXPECT_EQ(error_of(RtmTest::_tc_TimedMixed, Words{"1", "yes", "RUN"}),
            "on: 'yes' is not a boolean (true, false, 1 or 0)");
}

TEST_F(RtmValuesOfAnyStruct, OutOfRangeIsRefusedForEachMemberType) {
  EXPECT_EQ(error_of(RtmTest::_tc_TimedMixed, Words{"1", "true", "RUN", "0", "1e39"}),
            "data[1]: '1e39' is out of the range of float (|x| <= 3.4e38)");
  EXPECT_EQ(error_of(RtmTest::_tc_TimedMixed, Words{"3000000000", "true", "RUN"}),
            "n: '3000000000' is out of the range of long (-2147483648 to 2147483647)");
  const Words scalars{"0", "-1", "0", "0", "0", "256", "A", "0", "x"};
  EXPECT_EQ(error_of(RtmTest::_tc_TimedScalars, scalars),
            "us: '-1' is out of the range of unsigned short (0 to 65535)");
  Words octet = scalars;
  octet[1] = "0";
  EXPECT_EQ(error_of(RtmTest::_tc_TimedScalars, octet), "o: '256' is out of the range of octet (0 to 255)");
  Words big = octet;
  big[5] = "0";
  big[4] = "1e20";
  EXPECT_EQ(error_of(RtmTest::_tc_TimedScalars, big),
            "ull: '1e20' is out of the range of unsigned long long (0 to 18446744073709551615)");
}

TEST_F(RtmValuesOfAnyStruct, UnknownEnumLabelIsRefusedListingTheLabels) {
  EXPECT_EQ(error_of(RtmTest::_tc_TimedMixed, Words{"1", "true", "FAST"}),
            "mode: 'FAST' is not one of IDLE, RUN (or their index, 0 to 1)");
  EXPECT_EQ(error_of(RtmTest::_tc_TimedMixed, Words{"1", "true", "2"}),
            "mode: '2' is not one of IDLE, RUN (or their index, 0 to 1)");
}

TEST_F(RtmValuesOfAnyStruct, SequenceFollowedByMembersIsRefused) {
  EXPECT_EQ(error_of(RtmTest::_tc_SequenceFirst, Words{"1", "2"}),
            "a is followed by n: rtm put fills a sequence only when it comes last");
}

TEST_F(RtmValuesOfAnyStruct, BuiltInTypesKeepTheirFormatAndGainFields) {
  RTM::TimedFloat3 d{};
  d.val[0] = 1;
  CORBA::Any any;
  any <<= d;
  EXPECT_EQ(rtm::cli::format_text(any), "1970-01-01T00:00:00.000000000Z  1.0000  0.0000  0.0000");
  auto j = rtm::cli::format_json(any);
  EXPECT_EQ(j["values"], (nlohmann::json{1.0, 0.0, 0.0}));
  EXPECT_EQ(j["fields"]["val"], (nlohmann::json{1.0, 0.0, 0.0}));
  RTM::TimedBoolean b{};
  b.data = true;
  any <<= b;
  EXPECT_EQ(rtm::cli::format_json(any)["fields"]["data"], true);
}

}  // namespace
