// SPDX-License-Identifier: Apache-2.0
// The demo's report on a motion script: its phase log read and refused, and a slide's force
// error and path computed from recordings made up here.
#include "script_report.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace {

using rtm::demo::ReportError;
using rtm::demo::Series;

constexpr const char* kHeader =
    "begin_ns,end_ns,motion,outcome,force_N,normal_x,normal_y,normal_z,along_x,along_y,along_z,description\n";

TEST(ScriptPhases, AreReadWithTheirForceNormalAndDirection) {
  const auto phases = rtm::demo::parse_script_phases(
      std::string(kHeader) +
          "100,200,approach,done,,,,,,,,\"approach -z at 5 mm/s until 2 N\"\n"
          "200,700,slide,done,10,0,0,-1,1,0,0,\"slide +x 50 mm, at 10 N\"\n",
      "phases.csv");
  ASSERT_EQ(phases.size(), 2u);
  EXPECT_EQ(phases[0].motion, "approach");
  EXPECT_FALSE(phases[0].force_N.has_value());
  EXPECT_FALSE(phases[0].normal.has_value());
  EXPECT_EQ(phases[1].begin_ns, 200);
  EXPECT_EQ(phases[1].end_ns, 700);
  EXPECT_EQ(*phases[1].force_N, 10);
  EXPECT_EQ((*phases[1].normal)[2], -1);
  EXPECT_EQ((*phases[1].along)[0], 1);
  EXPECT_EQ(phases[1].description, "slide +x 50 mm, at 10 N");  // a comma inside the quotes
}

TEST(ScriptPhases, AMalformedLogIsRefusedNamingTheLine) {
  const auto refused = [](const std::string& text) {
    try {
      rtm::demo::parse_script_phases(text, "p.csv");
    } catch (const ReportError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(refused("time_ns,fx\n").find("p.csv:1: expected the header"), std::string::npos);
  EXPECT_NE(refused("").find("p.csv: empty"), std::string::npos);
  EXPECT_NE(refused(std::string(kHeader) + "200,100,slide,done,10,0,0,-1,1,0,0,\"x\"\n").find("p.csv:2:"),
            std::string::npos);  // ends before it begins
  EXPECT_NE(refused(std::string(kHeader) + "1,2,slide,done,nan,0,0,-1,1,0,0,\"x\"\n").find("p.csv:2:"),
            std::string::npos);
  EXPECT_NE(refused(std::string(kHeader) + "1,2,slide,done,10,0,0,,1,0,0,\"x\"\n").find("p.csv:2:"),
            std::string::npos);  // a vector half given
  EXPECT_NE(refused(std::string(kHeader) + "1,2,slide,done,10,0,0,-1,1,0,0,x\n").find("p.csv:2:"),
            std::string::npos);  // no quotes
}

TEST(SlideFigures, MeasureTheForceAlongTheNormalAndTheDistanceFromTheLine) {
  rtm::demo::ScriptPhase slide;
  slide.begin_ns = 1000;
  slide.end_ns = 1000 + 99 * 10;
  slide.motion = "slide";
  slide.outcome = "done";
  slide.force_N = 10;
  slide.normal = std::array<double, 3>{0, 0, -1};
  slide.along = std::array<double, 3>{1, 0, 0};
  Series sensor, pose;
  for (int i = 0; i < 100; ++i) {
    const std::int64_t t = 1000 + i * 10;
    // The reaction reads +fz: the tool applies 10 N down, off by 0.1 N every tenth sample and
    // 2 N once.
    const double fz = 10 + (i % 10 == 0 ? 0.1 : 0) + (i == 55 ? 2 : 0);
    sensor.time_ns.push_back(t);
    sensor.values.push_back({0, 0, fz, 0, 0, 0});
    // 0.5 mm per sample along x, 1 mm off to +y from the 50th.
    pose.time_ns.push_back(t);
    pose.values.push_back({0.5 + 0.0005 * i, i >= 50 ? 0.001 : 0, 0.2, 0, 0, 0});
  }
  sensor.time_ns.push_back(5000);  // after the phase: not counted
  sensor.values.push_back({0, 0, 50, 0, 0, 0});
  const auto f = rtm::demo::slide_figures(slide, sensor, pose);
  EXPECT_EQ(f.force_samples, 100u);
  EXPECT_NEAR(f.error_p50_N, 0, 1e-12);
  EXPECT_NEAR(f.error_p99_N, 0.1, 1e-9);
  EXPECT_NEAR(f.error_max_N, 2, 1e-9);
  ASSERT_TRUE(f.travelled_m.has_value());
  EXPECT_NEAR(*f.travelled_m, 0.0495, 1e-9);
  EXPECT_NEAR(*f.deviation_max_m, 0.001, 1e-9);

  std::vector<std::string> missed;
  const auto text = rtm::demo::format_script_report({slide}, {f}, {}, missed);
  EXPECT_NE(text.find("p99 0.100 N (<= 0.5 N): ok"), std::string::npos) << text;
  EXPECT_NE(text.find("max 1.000 mm (<= 2 mm): ok"), std::string::npos) << text;
  EXPECT_TRUE(missed.empty());

  rtm::demo::ScriptLimits tight;
  tight.max_force_error_p99_N = 0.05;
  tight.max_deviation_m = 0.0005;
  rtm::demo::format_script_report({slide}, {f}, tight, missed);
  EXPECT_EQ(missed.size(), 2u);
}

TEST(SlideFigures, WithoutAPoseThePathIsNotMeasuredAndSaysSo) {
  rtm::demo::ScriptPhase slide;
  slide.begin_ns = 0;
  slide.end_ns = 10;
  slide.motion = "slide";
  slide.outcome = "stopped";
  slide.description = "slide +x";
  slide.force_N = 5;
  slide.normal = std::array<double, 3>{0, 0, -1};
  slide.along = std::array<double, 3>{1, 0, 0};
  Series sensor;
  sensor.time_ns = {5};
  sensor.values = {{0, 0, 5, 0, 0, 0}};
  const auto f = rtm::demo::slide_figures(slide, sensor, Series{});
  EXPECT_FALSE(f.deviation_max_m.has_value());
  std::vector<std::string> missed;
  const auto text = rtm::demo::format_script_report({slide}, {f}, {}, missed);
  EXPECT_NE(text.find("path: not measured"), std::string::npos) << text;
  ASSERT_EQ(missed.size(), 2u);  // the slide did not end done, and its path is not measured
  EXPECT_NE(missed[0].find("ended stopped"), std::string::npos);

  slide.force_N.reset();
  EXPECT_THROW(rtm::demo::slide_figures(slide, sensor, Series{}), ReportError);
}

TEST(ScriptRun, TheOperatorsFiguresGiveWayToTheScriptsAndTheWatchdogStays) {
  rtm::demo::Report report;  // no touch-down, no step, no release: each "not measured"
  report.timing.push_back({});
  report.timing.back().name = "actuator0";
  report.timing.back().statistics.push_back({"watchdog_events", 1, ""});
  rtm::demo::FigureLimits limits;
  limits.max_watchdog_events = 1;
  EXPECT_EQ(rtm::demo::evaluate_figures(report, {}, limits).size(), 5u);
  EXPECT_EQ(rtm::demo::missed_figures(report, {}, limits).size(), 4u);
  report.operator_figures = false;
  const auto verdicts = rtm::demo::evaluate_figures(report, {}, limits);
  ASSERT_EQ(verdicts.size(), 1u);
  EXPECT_EQ(verdicts[0].figure, "watchdog events");
  EXPECT_TRUE(verdicts[0].ok);
  EXPECT_TRUE(rtm::demo::missed_figures(report, {}, limits).empty());
}

}  // namespace
