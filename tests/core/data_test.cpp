// SPDX-License-Identifier: Apache-2.0
#include "rtm/data.h"

#include <gtest/gtest.h>

#include <chrono>
#include <limits>

namespace {

TEST(Data, NowIsWallClockTime) {
  const auto before_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
                             std::chrono::system_clock::now().time_since_epoch())
                             .count();
  const std::int64_t stamp_ns = rtm::to_ns(rtm::now());
  const auto after_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
                            std::chrono::system_clock::now().time_since_epoch())
                            .count();
  EXPECT_LE(before_ns, stamp_ns);
  EXPECT_LE(stamp_ns, after_ns);
  EXPECT_LT(rtm::now().nsec, 1'000'000'000u);
}

TEST(Data, NanosecondConversionRoundTrips) {
  const std::int64_t ns = 1'700'000'123'456'789'012LL / 1000;  // 1.7e9 s and a fraction
  const RTM::Time t = rtm::from_ns(ns);
  EXPECT_EQ(t.sec, static_cast<CORBA::ULong>(ns / 1'000'000'000));
  EXPECT_EQ(t.nsec, static_cast<CORBA::ULong>(ns % 1'000'000'000));
  EXPECT_EQ(rtm::to_ns(t), ns);
}

TEST(Data, TraitsMapEachTimedTypeToItsTypeCode) {
  EXPECT_TRUE(rtm::DataTraits<RTM::TimedFloat6>::type_code()->equivalent(RTM::_tc_TimedFloat6));
  EXPECT_TRUE(rtm::DataTraits<RTM::TimedFloat3>::type_code()->equivalent(RTM::_tc_TimedFloat3));
  EXPECT_TRUE(rtm::DataTraits<RTM::TimedDoubleSeq>::type_code()->equivalent(RTM::_tc_TimedDoubleSeq));
  EXPECT_FALSE(rtm::DataTraits<RTM::TimedFloat6>::type_code()->equivalent(RTM::_tc_TimedFloat3));
  EXPECT_EQ(rtm::DataTraits<RTM::TimedFloat6>::name, "RTM::TimedFloat6");
  EXPECT_EQ(rtm::DataTraits<RTM::TimedBoolean>::name, "RTM::TimedBoolean");
  EXPECT_TRUE(rtm::DataTraits<RTM::TimedLong>::fixed_size);
  EXPECT_FALSE(rtm::DataTraits<RTM::TimedFloatSeq>::fixed_size);
}

TEST(Data, TypeNameReadsIdlNamesAndBasicKinds) {
  EXPECT_EQ(rtm::type_name(RTM::_tc_TimedFloat6), "RTM::TimedFloat6");
  EXPECT_EQ(rtm::type_name(RTM::_tc_TimedDouble), "RTM::TimedDouble");
  EXPECT_EQ(rtm::type_name(CORBA::_tc_long), "long");
  EXPECT_EQ(rtm::type_name(CORBA::_tc_string), "string");
  EXPECT_EQ(rtm::type_name(CORBA::TypeCode::_nil()), "<nil>");
  // The name of the trait and the name read from the TypeCode agree for every type.
  EXPECT_EQ(rtm::type_name(rtm::DataTraits<RTM::TimedFloatSeq>::type_code()),
            rtm::DataTraits<RTM::TimedFloatSeq>::name);
}

TEST(Data, NonFiniteValuesAreDetected) {
  RTM::TimedFloat6 d{};
  EXPECT_FALSE(rtm::has_non_finite(d));
  d.val[5] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_TRUE(rtm::has_non_finite(d));
  d.val[5] = std::numeric_limits<float>::infinity();
  EXPECT_TRUE(rtm::has_non_finite(d));

  RTM::TimedDoubleSeq s{};
  s.data.length(3);
  s.data[0] = s.data[1] = s.data[2] = 1.0;
  EXPECT_FALSE(rtm::has_non_finite(s));
  s.data[2] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(rtm::has_non_finite(s));
}

}  // namespace
