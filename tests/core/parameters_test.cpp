// SPDX-License-Identifier: Apache-2.0
// A parameter declared once, as an rtm::Param field of its struct: the same line gives the
// executable's option and its help, the check of a value from the command line, from `rtm set`
// and from code, and what a component shows and changes.
#include "host/runner.h"
#include "rtm/component.h"
#include "rtm/parameters.h"

#include <CLI/App.hpp>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace {

struct GripParams {
  rtm::Param<std::array<float, 6>> gain{{1, 2, 3, 0, 0, 0}, {"gain", "1/s", "6 gains", rtm::ParameterAccess::live}};
  rtm::Param<float> force_N{5, {"force", "N", "grip force", rtm::ParameterAccess::live, rtm::above(0)}};
  rtm::Param<std::uint32_t> settle_periods{
      10, {"settle_periods", "cycles", "cycles to settle", rtm::ParameterAccess::when_off, rtm::between(1, 1000)}};
};

const rtm::ParameterTable<GripParams>& grip_parameters() {
  static const rtm::ParameterTable<GripParams> table{"grip"};
  return table;
}

std::string error_of(auto&& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

// Parses args (after the program's name) with the table's options; "" when accepted, else
// CLI11's message.
std::string parse(GripParams& params, std::vector<std::string> args) {
  CLI::App app{"grip"};
  rtm::add_parameter_options(app, grip_parameters(), params);
  std::vector<const char*> argv{"grip"};
  for (const auto& a : args) argv.push_back(a.c_str());
  try {
    app.parse(static_cast<int>(argv.size()), argv.data());
  } catch (const CLI::ParseError& e) {
    return e.what();
  }
  return "";
}

TEST(ParameterTable, EachParameterIsAnOptionNamedAfterItWithItsUnitInTheHelpAndItsFieldAsDefault) {
  GripParams params;
  CLI::App app{"grip"};
  rtm::add_parameter_options(app, grip_parameters(), params);
  const std::string help = app.help();
  EXPECT_NE(help.find("--settle-periods"), std::string::npos) << help;
  EXPECT_NE(help.find("grip force [N]"), std::string::npos) << help;
  EXPECT_NE(help.find("1 2 3 0 0 0"), std::string::npos) << "the default of --gain:\n" << help;

  EXPECT_EQ(parse(params, {"--force", "7.5", "--settle-periods", "20", "--gain", "1", "1", "1", "2", "2", "2"}), "");
  EXPECT_EQ(params.force_N, 7.5f);
  EXPECT_EQ(params.settle_periods, 20u);
  EXPECT_EQ(params.gain, (std::array<float, 6>{1, 1, 1, 2, 2, 2}));
}

TEST(ParameterTable, ACountOutOfItsBoundsIsRefusedByTheParserAndANumberByValidateNamingIt) {
  GripParams params;
  EXPECT_NE(parse(params, {"--settle-periods", "0"}).find("not in range 1 to 1000"), std::string::npos);
  EXPECT_EQ(parse(params, {"--force", "0", "--gain", "1", "1", "nan", "0", "0", "0"}), "");
  const std::string first = error_of([&] { grip_parameters().validate(params); });
  EXPECT_NE(first.find("grip gain[2] = nan is not a finite number"), std::string::npos) << first;
  params.gain[2] = 0;
  EXPECT_NE(error_of([&] { grip_parameters().validate(params); }).find("grip force = 0: must be above 0"),
            std::string::npos);
  params.force_N = 1;
  EXPECT_EQ(error_of([&] { grip_parameters().validate(params); }), "");
  params.settle_periods = 0;
  EXPECT_NE(error_of([&] { grip_parameters().validate(params); }).find("grip settle_periods must be at least 1"),
            std::string::npos);
}

TEST(ParameterTable, SetParsesTextChecksItAndLeavesTheValueAloneWhenItIsBad) {
  const auto& table = grip_parameters();
  GripParams params;
  const auto& force = table.entries()[1];
  force.set(params, "2.5", table.owner());
  EXPECT_EQ(params.force_N, 2.5f);
  EXPECT_EQ(force.get(params), "2.5");
  EXPECT_NE(error_of([&] { force.set(params, "-1", table.owner()); }).find("grip force = -1: must be above 0"),
            std::string::npos);
  EXPECT_NE(error_of([&] { force.set(params, "1e39", table.owner()); }).find("is not a finite number"),
            std::string::npos)
      << "a double beyond a float's range";
  EXPECT_FALSE(error_of([&] { force.set(params, "nan", table.owner()); }).empty());
  EXPECT_EQ(params.force_N, 2.5f);

  const auto& gain = table.entries()[0];
  EXPECT_FALSE(error_of([&] { gain.set(params, "1 2 3", table.owner()); }).empty()) << "three of six";
  gain.set(params, "0.5, 0.5, 0.5, 0, 0, 0.25", table.owner());
  EXPECT_EQ(gain.get(params), "0.5 0.5 0.5 0 0 0.25");

  const auto& settle = table.entries()[2];
  EXPECT_FALSE(error_of([&] { settle.set(params, "1001", table.owner()); }).empty());
  EXPECT_FALSE(error_of([&] { settle.set(params, "2.5", table.owner()); }).empty());
  settle.set(params, "1000", table.owner());
  EXPECT_EQ(params.settle_periods, 1000u);
}

TEST(ParameterTable, ANameDeclaredTwiceIsRefused) {
  struct Twice {
    rtm::Param<float> force_N{5, {"force", "N", "", rtm::ParameterAccess::live}};
    rtm::Param<float> grip_force_N{5, {"force", "N", "", rtm::ParameterAccess::live}};
  };
  EXPECT_THROW(rtm::ParameterTable<Twice>{"grip"}, std::invalid_argument);
}

TEST(ParameterTable, FindsEveryFieldOfTheStructInItsOrderWithItsDeclaration) {
  const auto& entries = grip_parameters().entries();
  ASSERT_EQ(entries.size(), 3u);
  EXPECT_EQ(entries[0].name, "gain");
  EXPECT_EQ(entries[1].name, "force");
  EXPECT_EQ(entries[1].bounds.min, 0.0);
  EXPECT_TRUE(entries[1].bounds.min_open);
  EXPECT_EQ(entries[2].name, "settle_periods");
  EXPECT_EQ(entries[2].unit, "cycles");
  EXPECT_EQ(entries[2].bounds.max, 1000.0);
  GripParams params;
  params.settle_periods = 7;
  EXPECT_EQ(entries[2].get(params), "7") << "the entry reads the field of its own position";
}

class Grip final : public rtm::Component {
 public:
  Grip() : Component("grip0", "grip") { add_parameters(grip_parameters(), live_); }
  void on_cycle(const rtm::CycleContext&) override {}
  rtm::LiveValue<GripParams> live_{GripParams{}};
};

TEST(ParameterTable, AComponentShowsEachParameterAndASetPublishesTheWholeStructForTheCycle) {
  Grip grip;
  const auto& shown = grip.parameters();
  ASSERT_EQ(shown.size(), 3u);
  EXPECT_EQ(shown[1].name, "force");
  EXPECT_EQ(shown[1].unit, "N");
  EXPECT_EQ(shown[2].access, rtm::ParameterAccess::when_off);
  EXPECT_EQ(shown[0].get(), "1 2 3 0 0 0");

  GripParams cycle;
  EXPECT_FALSE(grip.live_.take(cycle)) << "nothing published yet";
  shown[1].set("8");
  EXPECT_THROW(shown[2].set("0"), std::invalid_argument);
  // What `rtm set` says after "<component>: ": the parameter once, the value where it helps.
  EXPECT_EQ(error_of([&] { shown[1].set("-1"); }), "force = -1: must be above 0");
  EXPECT_EQ(error_of([&] { shown[0].set("1 2 3"); }), "gain: '1 2 3' holds 3 numbers; 6 expected");
  EXPECT_EQ(error_of([&] { shown[0].set("1 1 nan 1 1 1"); }), "gain: 'nan' is not a finite number");
  shown[2].set("30");
  ASSERT_TRUE(grip.live_.take(cycle));
  EXPECT_EQ(cycle.force_N, 8.0f);
  EXPECT_EQ(cycle.settle_periods, 30u) << "each set starts from the last published, not from the defaults";
  EXPECT_EQ(shown[1].get(), "8");
}

}  // namespace
