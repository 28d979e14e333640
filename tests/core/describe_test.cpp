// SPDX-License-Identifier: Apache-2.0
// Self-description: element lists, parameter values as text, and a port that would claim
// more elements than its datum holds.
#include "rtm/component.h"
#include "rtm/describe.h"

#include <gtest/gtest.h>

#include <array>
#include <stdexcept>

namespace {

TEST(Describe, ElementsPairNamesWithUnitsAndDashMeansNoUnit) {
  const auto e = rtm::elements("fx fy count", "N N -");
  ASSERT_EQ(e.size(), 3u);
  EXPECT_EQ(e[1].name, "fy");
  EXPECT_EQ(e[1].unit, "N");
  EXPECT_EQ(e[2].unit, "");
}

TEST(Describe, ElementsWithMoreNamesThanUnitsAreRefusedNamingBoth) {
  try {
    rtm::elements("fx fy fz", "N N");
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("3 names ('fx fy fz') but 2 units"), std::string::npos) << e.what();
  }
}

TEST(Describe, ParseNumbersTakesSpacesOrCommasAndRefusesWordsNanAndWrongCounts) {
  EXPECT_EQ(rtm::parse_numbers("1, 2.5 -3e-3", 3), (std::vector<double>{1, 2.5, -3e-3}));
  EXPECT_THROW(rtm::parse_numbers("1 2", 3), std::invalid_argument);
  EXPECT_THROW(rtm::parse_numbers("1 x 3", 3), std::invalid_argument);
  EXPECT_THROW(rtm::parse_numbers("nan"), std::invalid_argument);
  EXPECT_THROW(rtm::parse_numbers("inf"), std::invalid_argument);
  EXPECT_THROW(rtm::parse_numbers(""), std::invalid_argument);
  EXPECT_THROW(rtm::parse_numbers("1.5e"), std::invalid_argument);
}

TEST(Describe, WholeNumbersOutsideTheirRangeOrWithFractionsAreRefused) {
  EXPECT_EQ(rtm::parse_whole_number("7", 1, 10), 7u);
  EXPECT_THROW(rtm::parse_whole_number("0", 1, 10), std::invalid_argument);
  EXPECT_THROW(rtm::parse_whole_number("11", 1, 10), std::invalid_argument);
  EXPECT_THROW(rtm::parse_whole_number("2.5", 1, 10), std::invalid_argument);
}

TEST(Describe, FormattedNumbersReadBackExactly) {
  const std::array<float, 3> values{0.003f, -1.0f, 1e-7f};
  const auto back = rtm::parse_numbers(rtm::format_numbers(std::span<const float>(values)), 3);
  for (std::size_t i = 0; i < 3; ++i) EXPECT_EQ(static_cast<float>(back[i]), values[i]);
}

class Described final : public rtm::Component {
 public:
  Described() : Component("d", "test") {}
  void on_cycle(const rtm::CycleContext&) override {}
  void add_wrong_port() { add_out_port<RTM::TimedFloat3>("p", {"three values", rtm::elements("a b", "m m")}); }
  void add_stat(const std::string& name) { add_statistic(name, "", "x", [] { return 1.0; }); }
  void add_writable_without_set() {
    add_parameter({.name = "w", .access = rtm::ParameterAccess::live, .get = [] { return std::string("1"); }});
  }
};

TEST(Describe, APortDescribedWithTheWrongNumberOfElementsIsRefused) {
  Described d;
  try {
    d.add_wrong_port();
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("d.p: 2 elements described, but a datum holds 3"), std::string::npos)
        << e.what();
  }
}

TEST(Describe, AStatisticNamedTwiceOrAWritableParameterWithoutSetIsRefused) {
  Described d;
  d.add_stat("cycles");
  EXPECT_THROW(d.add_stat("cycles"), std::invalid_argument);
  EXPECT_THROW(d.add_stat(""), std::invalid_argument);
  EXPECT_THROW(d.add_writable_without_set(), std::invalid_argument);
  EXPECT_EQ(d.statistics().size(), 1u);
  EXPECT_TRUE(d.parameters().empty());
}

}  // namespace
