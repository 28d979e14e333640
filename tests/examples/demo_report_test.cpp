// SPDX-License-Identifier: Apache-2.0
// rtm-demo-report's arithmetic on synthetic recordings whose answers are known in closed form.
#include "demo_report.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>

namespace {

using rtm::demo::PhaseOptions;
using rtm::demo::ReportError;
using rtm::demo::Sample;
using rtm::demo::Series;

constexpr std::int64_t kPeriod_ns = 2'000'000;
constexpr std::int64_t kEpoch_ns = 1'700'000'000'000'000'000;  // a CLOCK_REALTIME-like stamp

// A stream sampled every 2 ms for duration_s; force(t) fills values 0..2.
Series make_series(double duration_s, const std::function<std::array<double, 3>(double)>& force,
                   std::int64_t offset_ns = 0) {
  Series s;
  const auto n = static_cast<std::int64_t>(duration_s * 1e9 / kPeriod_ns);
  for (std::int64_t i = 0; i < n; ++i) {
    const double t_s = static_cast<double>(i * kPeriod_ns) * 1e-9;
    const auto f = force(t_s);
    s.time_ns.push_back(kEpoch_ns + offset_ns + i * kPeriod_ns);
    s.values.push_back({f[0], f[1], f[2], 0, 0, 0});
  }
  return s;
}

// The operator presses 10 N down from t = 1 s; the measured force follows a first-order lag
// of time constant tau_s (sensor reads the reaction, so it is the negative).
struct StepRecording {
  double tau_s = 0.2;
  double duration_s = 4.0;
  Series reference() const {
    return make_series(duration_s, [](double t) { return std::array<double, 3>{0, 0, t >= 1.0 ? -10.0 : 0.0}; });
  }
  Series sensor() const {
    return make_series(duration_s, [this](double t) {
      const double measured = t >= 1.0 ? -10.0 * (1 - std::exp(-(t - 1.0) / tau_s)) : 0.0;
      return std::array<double, 3>{0, 0, -measured};
    });
  }
  Series command() const {
    return make_series(duration_s, [](double) { return std::array<double, 3>{0, 0, 0}; }, 500'000);
  }
};

TEST(DemoReportCsv, ParsesRtmWatchOutputAndToleratesACutLastLine) {
  const Series s = rtm::demo::parse_watch_csv(
      "time_ns,v0,v1,v2,v3,v4,v5\n100,1,2,3,4,5,6\n200,-1.5,0,0,0,0,1e-3\n300,1,2", "rec.csv");
  ASSERT_EQ(s.time_ns.size(), 2u);
  EXPECT_EQ(s.time_ns[1], 200);
  EXPECT_DOUBLE_EQ(s.values[0][5], 6.0);
  EXPECT_DOUBLE_EQ(s.values[1][0], -1.5);
  EXPECT_DOUBLE_EQ(s.values[1][5], 1e-3);
}

// The live display reads the newest whole row: a line still being written (no '\n' yet, here
// "300,7,8,9,1,2,3" that may yet grow digits) is not one, nor the header.
TEST(DemoReportLive, TheNewestCompleteRowIsTheLastLineEndedByANewlineThatHoldsSevenNumbers) {
  const auto row = rtm::demo::last_complete_row("time_ns,v0,v1,v2,v3,v4,v5\n100,1,2,3,4,5,6\n200,0.5,0,-10,0,0,0\n300,7,8,9,1,2,3");
  ASSERT_TRUE(row.has_value());
  EXPECT_DOUBLE_EQ((*row)[0], 200.0);
  EXPECT_DOUBLE_EQ((*row)[3], -10.0);
  EXPECT_FALSE(rtm::demo::last_complete_row("time_ns,v0,v1,v2,v3,v4,v5\n").has_value());
  EXPECT_FALSE(rtm::demo::last_complete_row("time_ns,v0,v1,v2,v3,v4,v5\n100,1,2").has_value());
  EXPECT_FALSE(rtm::demo::last_complete_row("").has_value());
  const auto after_bad = rtm::demo::last_complete_row("100,1,2,3,4,5,6\n200,1,2\n");
  ASSERT_TRUE(after_bad.has_value()) << "a short line is skipped for the one before it";
  EXPECT_DOUBLE_EQ((*after_bad)[0], 100.0);
}

// From a file: only its last 4 KiB are read, and a row cut at the front of that tail is not taken
// for a whole one.
TEST(DemoReportLive, AFilesNewestRowIsFoundInItsTailAndAMissingFileHasNone) {
  const auto path = std::filesystem::temp_directory_path() / ("demo-live-" + std::to_string(::getpid()) + ".csv");
  EXPECT_FALSE(rtm::demo::last_complete_row_of(path).has_value());
  {
    std::ofstream out(path);
    out << "time_ns,v0,v1,v2,v3,v4,v5\n";
    for (int i = 1; i <= 2000; ++i) out << i << ",1,2,3,4,5,6\n";
    out << "2001,1,2";  // being written
  }
  const auto row = rtm::demo::last_complete_row_of(path);
  std::filesystem::remove(path);
  ASSERT_TRUE(row.has_value());
  EXPECT_DOUBLE_EQ((*row)[0], 2000.0);
}

TEST(DemoReportLive, TheLineNamesThePhaseFromTheReference) {
  const rtm::demo::Row none{};
  const rtm::demo::Row press{0, 0, 0, -10, 0, 0, 0}, push{0, 5, 0, -1, 0, 0, 0};
  const rtm::demo::Row sensor{0, 0.5, 0, 9.5, 0, 0, 0}, command{0, 0, 0, -0.002, 0, 0, 0};
  EXPECT_NE(rtm::demo::live_line(1, none, none, none).find("hands off"), std::string::npos);
  const std::string pressing = rtm::demo::live_line(12, press, sensor, command);
  EXPECT_NE(pressing.find("press 10 N"), std::string::npos) << pressing;
  EXPECT_NE(pressing.find("   -0.5"), std::string::npos) << "the measured force is the sensor's negative: " << pressing;
  EXPECT_NE(pressing.find("   -2.0"), std::string::npos) << "velocity in mm/s: " << pressing;
  EXPECT_NE(rtm::demo::live_line(3, push, none, none).find("free-space push"), std::string::npos);
}

TEST(DemoReportCsv, MalformedRowNamesFileAndLine) {
  try {
    rtm::demo::parse_watch_csv("time_ns,v0,v1,v2,v3,v4,v5\n100,1,2,3,4,5,6\n200,1,x,3,4,5,6\n", "rec.csv");
    FAIL() << "no error for a non-number";
  } catch (const ReportError& e) {
    EXPECT_NE(std::string(e.what()).find("rec.csv:3"), std::string::npos) << e.what();
  }
  EXPECT_THROW(rtm::demo::parse_watch_csv("1,2,3\n", "nohead.csv"), ReportError);
  EXPECT_THROW(rtm::demo::parse_watch_csv("", "empty.csv"), ReportError);
  EXPECT_THROW(rtm::demo::read_watch_csv("/nonexistent/rec.csv"), ReportError);
}

TEST(DemoReportAlign, UsesTheLatestReferenceAndCommandAtOrBeforeEachSensorSample) {
  Series reference{{100, 300}, {{{1, 0, 0, 0, 0, 0}}, {{2, 0, 0, 0, 0, 0}}}};
  Series sensor{{50, 100, 200, 300, 400}, {}};
  for (int i = 0; i < 5; ++i) sensor.values.push_back({0, 0, static_cast<double>(i), 0, 0, 0});
  Series command{{250}, {{{0.1, 0.2, 0.3, 0, 0, 0}}}};
  const auto samples = rtm::demo::align(reference, sensor, command);
  ASSERT_EQ(samples.size(), 4u);  // the sensor sample at 50 ns precedes every reference
  EXPECT_DOUBLE_EQ(samples[0].time_s, 0.0);
  EXPECT_DOUBLE_EQ(samples[0].reference_N[0], 1.0);
  EXPECT_DOUBLE_EQ(samples[0].measured_N[2], -1.0);  // measured = -sensor
  EXPECT_DOUBLE_EQ(samples[0].velocity[0], 0.0);     // no command yet
  EXPECT_DOUBLE_EQ(samples[2].reference_N[0], 2.0);
  EXPECT_DOUBLE_EQ(samples[2].velocity[2], 0.3);
  EXPECT_DOUBLE_EQ(samples[3].time_s, 300e-9);
}

TEST(DemoReportAlign, StreamsOnDifferentClocksAreRefused) {
  Series reference{{100}, {{}}};
  Series sensor{{5'000'000'000}, {{}}};
  Series command{{5'000'000'000}, {{}}};
  EXPECT_THROW(rtm::demo::align(reference, sensor, command), ReportError);
  EXPECT_THROW(rtm::demo::align(Series{}, sensor, command), ReportError);
}

TEST(DemoReportPhases, ConstantStretchesAreFoundAndRampsSkipped) {
  // 0 N for 1 s, ramp to -10 N over 1 s, hold 2 s, step to -20 N, hold 1 s, 0.2 s blip.
  const auto profile = [](double t) -> std::array<double, 3> {
    if (t < 1.0) return {0, 0, 0};
    if (t < 2.0) return {0, 0, -10.0 * (t - 1.0)};
    if (t < 4.0) return {0, 0, -10};
    if (t < 5.0) return {0, 0, -20};
    return {0, 0, -5};
  };
  const Series ref = make_series(5.2, profile);
  const auto samples = rtm::demo::align(ref, ref, ref);
  const auto phases = rtm::demo::detect_phases(samples, PhaseOptions{});
  ASSERT_EQ(phases.size(), 3u);
  EXPECT_NEAR(samples[phases[0].begin].time_s, 0.0, 1e-9);
  EXPECT_NEAR(samples[phases[0].end - 1].time_s, 1.0, 0.006);  // the ramp's first 0.05 N
  EXPECT_NEAR(samples[phases[1].begin].time_s, 2.0, 0.006);  // within 0.05 N of -10 N
  EXPECT_NEAR(samples[phases[2].begin].time_s, 4.0, 1e-9);
  EXPECT_EQ(phases[2].end, samples.size() - 100);  // the 0.2 s blip is no phase
}

TEST(DemoReportSummary, FirstOrderStepSettlesAtTauTimesLnOfRangeOverBand) {
  const StepRecording rec;
  const auto samples = rtm::demo::align(rec.reference(), rec.sensor(), rec.command());
  PhaseOptions options;
  const auto phases = rtm::demo::detect_phases(samples, options);
  ASSERT_EQ(phases.size(), 2u);
  const auto press = rtm::demo::summarize(samples, phases[1], options);
  EXPECT_TRUE(press.contact);
  EXPECT_DOUBLE_EQ(press.reference_N[2], -10.0);
  ASSERT_TRUE(press.settling_time_s.has_value());
  // |error| = 10 exp(-t/tau) <= 0.5  <=>  t >= tau ln(20); sampled every 2 ms.
  EXPECT_NEAR(*press.settling_time_s, rec.tau_s * std::log(20.0), 0.0021);
  // Last second: t - 1 in [2, 3] s, mean of 10 exp(-x/0.2) over it is tiny.
  EXPECT_LT(press.steady_error_N, 1e-3);
  EXPECT_NEAR(press.mean_measured_N[2], -10.0, 1e-3);

  const auto idle = rtm::demo::summarize(samples, phases[0], options);
  EXPECT_FALSE(idle.contact);
}

TEST(DemoReportSummary, OscillationAroundTheReferenceNeverSettlesAndShowsPeakToPeak) {
  // Chatter: measured = 10 + 1.0 sin(2 pi 20 t): mean is right, but it never enters a 0.5 N band.
  const auto ref = make_series(3.0, [](double) { return std::array<double, 3>{0, 0, -10}; });
  const auto sen = make_series(3.0, [](double t) {
    return std::array<double, 3>{0, 0, 10 + 1.0 * std::sin(2 * M_PI * 20 * t)};
  });
  const auto samples = rtm::demo::align(ref, sen, ref);
  PhaseOptions options;
  const auto phases = rtm::demo::detect_phases(samples, options);
  ASSERT_EQ(phases.size(), 1u);
  const auto s = rtm::demo::summarize(samples, phases[0], options);
  EXPECT_FALSE(s.settling_time_s.has_value());
  EXPECT_LT(s.steady_error_N, 0.05);
  EXPECT_GT(s.error_peak_to_peak_N, 0.9);
}

TEST(DemoReportSummary, FrictionAcrossTheReferenceIsLateralNotForceError) {
  // Pressing down at 10 N exactly while sliding: 2 N of friction along x.
  const auto ref = make_series(3.0, [](double) { return std::array<double, 3>{0, 0, -10}; });
  const auto sen = make_series(3.0, [](double) { return std::array<double, 3>{-2, 0, 9.7}; });
  const auto samples = rtm::demo::align(ref, sen, ref);
  const auto phases = rtm::demo::detect_phases(samples, PhaseOptions{});
  ASSERT_EQ(phases.size(), 1u);
  const auto s = rtm::demo::summarize(samples, phases[0], PhaseOptions{});
  EXPECT_TRUE(s.contact);
  EXPECT_NEAR(s.steady_error_N, 0.3, 1e-9);
  EXPECT_NEAR(s.lateral_N, 2.0, 1e-9);
  ASSERT_TRUE(s.settling_time_s.has_value());
  EXPECT_DOUBLE_EQ(*s.settling_time_s, 0.0);
}

TEST(DemoReportSummary, FreeSpacePushIsNoContactAndReportsTheVelocity) {
  const auto ref = make_series(2.0, [](double) { return std::array<double, 3>{5, 0, 0}; });
  const auto sen = make_series(2.0, [](double) { return std::array<double, 3>{0.1, 0, 0}; });
  Series cmd = ref;
  for (auto& v : cmd.values) v = {0.025, 0, 0, 0, 0, 0};
  const auto samples = rtm::demo::align(ref, sen, cmd);
  const auto phases = rtm::demo::detect_phases(samples, PhaseOptions{});
  ASSERT_EQ(phases.size(), 1u);
  const auto s = rtm::demo::summarize(samples, phases[0], PhaseOptions{});
  EXPECT_FALSE(s.contact);
  EXPECT_NEAR(s.mean_velocity_m_s[0], 0.025, 1e-12);
  EXPECT_THROW(rtm::demo::summarize(samples, {5, 5}, PhaseOptions{}), std::invalid_argument);
  EXPECT_THROW(rtm::demo::summarize(samples, {0, samples.size() + 1}, PhaseOptions{}), std::invalid_argument);
}

TEST(DemoReportTiming, ParsesRtmLsJsonIncludingDeadAndUntimedComponents) {
  const auto timing = rtm::demo::parse_timing_json(R"([
    {"host":"h","name":"sensor0","alive":true,"kind":"sensor","state":"ON","period_ns":2000000,
     "timing":{"cycles":5000,"overruns":2,"lateness_p50_ns":30000,"lateness_p99_ns":91000,
               "lateness_max_ns":4100000,"mean_period_error_ns":1.5},"ports":[]},
    {"host":"h","name":"servo0","alive":true,"kind":"servo","state":"ERROR","last_error":"arm fault","ports":[],
     "statistics":{"watchdog_events":{"value":2,"unit":"","description":"x"},
                   "latency_p99":{"value":61.5,"unit":"us","description":"y"}}},
    {"host":"h","name":"gone0","alive":false,"dead_reason":"TRANSIENT"}])", "t.json");
  ASSERT_EQ(timing.size(), 3u);
  EXPECT_EQ(timing[0].overruns, 2u);
  EXPECT_EQ(timing[0].lateness_p99_ns, 91000);
  EXPECT_EQ(timing[1].cycles, 0u);
  EXPECT_EQ(timing[1].last_error, "arm fault");
  EXPECT_EQ(timing[0].last_error, "");
  EXPECT_EQ(timing[2].state, "dead");
  ASSERT_EQ(timing[1].statistics.size(), 2u);
  const auto latency = rtm::demo::find_statistic(timing, "latency_p99");
  ASSERT_TRUE(latency.has_value());
  EXPECT_EQ(latency->component, "servo0");
  EXPECT_DOUBLE_EQ(latency->statistic.value, 61.5);
  EXPECT_EQ(latency->statistic.unit, "us");
  EXPECT_FALSE(rtm::demo::find_statistic(timing, "latency_p50").has_value());
  EXPECT_THROW(rtm::demo::parse_timing_json("{not json", "t.json"), ReportError);
  EXPECT_THROW(rtm::demo::parse_timing_json(R"({"a":1})", "t.json"), ReportError);
  EXPECT_THROW(rtm::demo::parse_timing_json(R"([{"alive":true}])", "t.json"), ReportError);
}

TEST(DemoReportOutput, SummaryCsvAndPlotScriptCarryThePhases) {
  const StepRecording rec;
  const auto samples = rtm::demo::align(rec.reference(), rec.sensor(), rec.command());
  PhaseOptions options;
  rtm::demo::Report report;
  for (const auto& p : rtm::demo::detect_phases(samples, options))
    report.phases.push_back(rtm::demo::summarize(samples, p, options));
  rtm::demo::ComponentTiming actuator;
  actuator.name = "actuator0";
  actuator.statistics = {{"watchdog_events", 0, ""}, {"latency_p50", 31, "us"}, {"latency_p99", 58.5, "us"},
                         {"latency_max", 900, "us"}, {"command_loss_recoveries", 1, ""}};
  report.timing.push_back(actuator);
  report.samples = samples.size();
  const std::string text = rtm::demo::format_report(report, options);
  EXPECT_NE(text.find("contact"), std::string::npos) << text;
  EXPECT_NE(text.find("-10.0"), std::string::npos) << text;
  EXPECT_NE(text.find("Watchdog events (actuator0): 0"), std::string::npos) << text;
  EXPECT_NE(text.find("(actuator0): p50 31 us, p99 58.5 us, max 900 us"), std::string::npos) << text;
  EXPECT_NE(text.find("Drive command-loss recoveries (actuator0): 1"), std::string::npos) << text;

  const auto dir = std::filesystem::temp_directory_path() / ("rtm_demo_report_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  rtm::demo::write_samples_csv(dir / "f.csv", samples);
  std::ifstream in(dir / "f.csv");
  std::string header, first;
  std::getline(in, header);
  std::getline(in, first);
  EXPECT_EQ(header.rfind("time_s,ref_x_N", 0), 0u);
  EXPECT_EQ(first.rfind("0.0000,0.000,0.000,0.000", 0), 0u) << first;
  std::size_t rows = 1;
  for (std::string line; std::getline(in, line);) ++rows;
  EXPECT_EQ(rows, samples.size());
  std::filesystem::remove_all(dir);

  const std::string gp = rtm::demo::gnuplot_script("/o/f.csv", "/o/f.png", report.phases);
  EXPECT_NE(gp.find("set output '/o/f.png'"), std::string::npos);
  EXPECT_NE(gp.find("set arrow from 1.000"), std::string::npos) << gp;
}

// ============================ demo figures ============================

using rtm::demo::DemoFigures;
using rtm::demo::FigureLimits;
using rtm::demo::FigureVerdict;

// A press straight down: the reference is press(t) N down, the hand's force force(t) N down
// (the sensor reads the reaction, +force along z).
std::vector<Sample> press_run(double duration_s, const std::function<double(double)>& press,
                              const std::function<double(double)>& force) {
  const Series ref = make_series(duration_s, [&](double t) { return std::array<double, 3>{0, 0, -press(t)}; });
  const Series sen = make_series(duration_s, [&](double t) { return std::array<double, 3>{0, 0, force(t)}; });
  const Series cmd = make_series(duration_s, [](double) { return std::array<double, 3>{0, 0, 0}; }, 500'000);
  return rtm::demo::align(ref, sen, cmd);
}

DemoFigures figures_of(const std::vector<Sample>& samples, const FigureLimits& limits = {}) {
  const PhaseOptions options;
  return rtm::demo::compute_figures(samples, rtm::demo::detect_phases(samples, options), options, limits);
}

// Hands off for 0.5 s, then a 10 N press; the tool descends in free space and touches at
// 1.0 s: the force rises linearly to 10 (1 + overshoot) N in 20 ms, then relaxes to 10 N with
// time constant tau_s. Peak exactly 10 (1 + overshoot); settled (|error| <= 0.5 N) at
// 1.02 + tau ln(10 overshoot / 0.5) s.
struct TouchDownRecording {
  double overshoot = 0.35;
  double tau_s = 0.05;
  static constexpr double kTouch_s = 1.0, kRise_s = 0.02;
  double peak_N() const { return 10 * (1 + overshoot); }
  double force(double t) const {
    if (t < kTouch_s) return 0;
    if (t < kTouch_s + kRise_s) return peak_N() * (t - kTouch_s) / kRise_s;
    return 10 + (peak_N() - 10) * std::exp(-(t - kTouch_s - kRise_s) / tau_s);
  }
  std::vector<Sample> samples() const {
    return press_run(3.0, [](double t) { return t >= 0.5 ? 10.0 : 0.0; }, [this](double t) { return force(t); });
  }
  // The first 2 ms sample at or above 1 N on the rise.
  double touch_down_s() const { return kTouch_s + std::ceil(kRise_s / peak_N() / 0.002 - 1e-9) * 0.002; }
  double settled_s() const { return kTouch_s + kRise_s + tau_s * std::log(10 * overshoot / 0.5); }
};

const FigureVerdict& verdict(const std::vector<FigureVerdict>& verdicts, const std::string& figure, int nth = 0) {
  for (const auto& v : verdicts)
    if (v.figure == figure && nth-- == 0) return v;
  throw std::runtime_error("no verdict " + figure);
}

rtm::demo::Report report_of(const std::vector<Sample>& samples, double watchdog_events = 0) {
  const PhaseOptions options;
  rtm::demo::Report report;
  const auto phases = rtm::demo::detect_phases(samples, options);
  for (const auto& p : phases) report.phases.push_back(rtm::demo::summarize(samples, p, options));
  report.figures = rtm::demo::compute_figures(samples, phases, options);
  rtm::demo::ComponentTiming actuator;
  actuator.name = "actuator0";
  actuator.statistics = {{"watchdog_events", watchdog_events, ""}};
  report.timing.push_back(actuator);
  report.samples = samples.size();
  report.duration_s = samples.back().time_s;
  return report;
}

TEST(DemoReportFigures, TouchDownOvershootOf35PercentIsMissed) {
  const TouchDownRecording rec{0.35, 0.05};
  const DemoFigures f = figures_of(rec.samples());
  ASSERT_EQ(f.touch_downs.size(), 1u);
  const auto& touch = f.touch_downs[0];
  EXPECT_NEAR(touch.time_s, rec.touch_down_s(), 1e-9);
  EXPECT_NEAR(touch.peak_N, 13.5, 1e-6);
  EXPECT_NEAR(touch.peak_time_s, 1.02, 1e-9);
  EXPECT_NEAR(touch.peak_reference_N, 10.0, 1e-12);
  EXPECT_NEAR(touch.overshoot, 0.35, 1e-6);
  EXPECT_DOUBLE_EQ(touch.reference_N[2], -10.0);
  ASSERT_TRUE(touch.settling_time_s.has_value());
  EXPECT_NEAR(*touch.settling_time_s, rec.settled_s() - rec.touch_down_s(), 0.0021);
  EXPECT_TRUE(f.steps.empty());  // the press phase began in free space

  const auto report = report_of(rec.samples());
  const auto verdicts = rtm::demo::evaluate_figures(report, PhaseOptions{});
  EXPECT_FALSE(verdict(verdicts, "touch-down overshoot").ok);
  EXPECT_EQ(verdict(verdicts, "touch-down overshoot").limit, "<= 20 %");
  EXPECT_TRUE(verdict(verdicts, "settling after touch-down").ok);  // about 0.12 s
  const auto missed = rtm::demo::missed_figures(report, PhaseOptions{});
  ASSERT_FALSE(missed.empty());
  EXPECT_EQ(missed[0].rfind("touch-down overshoot: 35.0 %", 0), 0u) << missed[0];
}

TEST(DemoReportFigures, TouchDownOvershootOf10PercentPasses) {
  const TouchDownRecording rec{0.10, 0.05};
  const DemoFigures f = figures_of(rec.samples());
  ASSERT_EQ(f.touch_downs.size(), 1u);
  EXPECT_NEAR(f.touch_downs[0].overshoot, 0.10, 1e-6);
  ASSERT_TRUE(f.touch_downs[0].settling_time_s.has_value());
  EXPECT_NEAR(*f.touch_downs[0].settling_time_s, rec.settled_s() - rec.touch_down_s(), 0.0021);
  const auto verdicts = rtm::demo::evaluate_figures(report_of(rec.samples()), PhaseOptions{});
  EXPECT_TRUE(verdict(verdicts, "touch-down overshoot").ok);
  EXPECT_TRUE(verdict(verdicts, "settling after touch-down").ok);
  // A tighter limit from the options turns the same run into a miss.
  FigureLimits tight;
  tight.max_overshoot = 0.05;
  EXPECT_FALSE(verdict(rtm::demo::evaluate_figures(report_of(rec.samples()), PhaseOptions{}, tight),
                       "touch-down overshoot").ok);
}

TEST(DemoReportFigures, SlowSettlingAfterTouchDownIsMissed) {
  // 10 % overshoot relaxing with tau = 0.5 s: settled 0.02 + 0.5 ln 2 = 0.37 s after contact.
  const TouchDownRecording rec{0.10, 0.5};
  const DemoFigures f = figures_of(rec.samples());
  ASSERT_EQ(f.touch_downs.size(), 1u);
  ASSERT_TRUE(f.touch_downs[0].settling_time_s.has_value());
  EXPECT_NEAR(*f.touch_downs[0].settling_time_s, rec.settled_s() - rec.touch_down_s(), 0.0021);
  EXPECT_GT(*f.touch_downs[0].settling_time_s, 0.3);
  const auto verdicts = rtm::demo::evaluate_figures(report_of(rec.samples()), PhaseOptions{});
  EXPECT_TRUE(verdict(verdicts, "touch-down overshoot").ok);
  EXPECT_FALSE(verdict(verdicts, "settling after touch-down").ok);
}

TEST(DemoReportFigures, TouchDownThatNeverSettlesBeforeThePhaseEndsIsMissed) {
  // Chatter on the table: 10 + 2 sin(2 pi 10 t) N from the touch-down on.
  const auto samples = press_run(2.0, [](double t) { return t >= 0.5 ? 10.0 : 0.0; },
                                 [](double t) { return t < 1.0 ? 0.0 : 10 + 2 * std::sin(2 * M_PI * 10 * (t - 1.0)) + 0.5; });
  const DemoFigures f = figures_of(samples);
  ASSERT_EQ(f.touch_downs.size(), 1u);
  EXPECT_FALSE(f.touch_downs[0].settling_time_s.has_value());
  EXPECT_NEAR(f.touch_downs[0].window_end_s, samples.back().time_s, 1e-9);  // to the phase end
  EXPECT_NEAR(f.touch_downs[0].overshoot, 0.25, 1e-3);
  EXPECT_FALSE(verdict(rtm::demo::evaluate_figures(report_of(samples), PhaseOptions{}), "settling after touch-down").ok);
}

TEST(DemoReportFigures, BounceInsideTheTransientIsOneTouchDown) {
  // 15 N impact for 10 ms, a bounce off (0.5 N) for 20 ms, then down to stay.
  const auto samples = press_run(3.0, [](double t) { return t >= 0.5 ? 10.0 : 0.0; }, [](double t) {
    if (t < 1.0) return 0.0;
    if (t < 1.01) return 15.0;
    if (t < 1.03) return 0.5;
    return 10 + 2 * std::exp(-(t - 1.03) / 0.05);
  });
  const DemoFigures f = figures_of(samples);
  ASSERT_EQ(f.touch_downs.size(), 1u);
  EXPECT_NEAR(f.touch_downs[0].time_s, 1.0, 1e-9);
  EXPECT_NEAR(f.touch_downs[0].overshoot, 0.5, 1e-9);
}

TEST(DemoReportFigures, TouchDownDuringTheRampIsJudgedOnTheReferenceItReaches) {
  // The reference ramps 0 -> 10 N over [0.5, 1.5] s; the tool touches at 1.0 s (5 N) and the
  // force then follows the reference exactly: no overshoot, settled at once.
  const auto ramp = [](double t) { return std::clamp(10 * (t - 0.5), 0.0, 10.0); };
  const auto samples = press_run(3.0, ramp, [&](double t) { return t < 1.0 ? 0.0 : ramp(t); });
  const DemoFigures f = figures_of(samples);
  ASSERT_EQ(f.touch_downs.size(), 1u);
  EXPECT_NEAR(f.touch_downs[0].time_s, 1.0, 1e-9);
  EXPECT_NEAR(f.touch_downs[0].overshoot, 0.0, 1e-9);
  ASSERT_TRUE(f.touch_downs[0].settling_time_s.has_value());
  EXPECT_DOUBLE_EQ(*f.touch_downs[0].settling_time_s, 0.0);
}

TEST(DemoReportFigures, FreeSpacePushIsNoTouchDownAndLeavesThePressFiguresUnmeasured) {
  const auto ref = make_series(2.0, [](double) { return std::array<double, 3>{5, 0, 0}; });
  const auto sen = make_series(2.0, [](double) { return std::array<double, 3>{-0.2, 0, 0}; });
  const auto samples = rtm::demo::align(ref, sen, ref);
  const DemoFigures f = figures_of(samples);
  EXPECT_TRUE(f.touch_downs.empty());
  EXPECT_TRUE(f.steps.empty());
  EXPECT_FALSE(f.release.has_value());
  const auto verdicts = rtm::demo::evaluate_figures(report_of(samples), PhaseOptions{});
  for (const char* figure : {"touch-down overshoot", "settling after touch-down", "settling after a step in contact",
                             "touch/lift transitions at release"}) {
    EXPECT_FALSE(verdict(verdicts, figure).ok) << figure;
    EXPECT_EQ(verdict(verdicts, figure).value.rfind("not measured", 0), 0u) << verdict(verdicts, figure).value;
  }
  EXPECT_TRUE(verdict(verdicts, "watchdog events").ok);
}

// In contact at 10 N; the reference ramps to 20 N over [1.0, 1.5] s while the force stays at
// 10 N, then the force follows first-order with time constant tau_s.
std::vector<Sample> step_in_contact(double tau_s) {
  return press_run(3.0, [](double t) { return std::clamp(10 + 20 * (t - 1.0), 10.0, 20.0); },
                   [tau_s](double t) { return t < 1.5 ? 10.0 : 20 - 10 * std::exp(-(t - 1.5) / tau_s); });
}

TEST(DemoReportFigures, StepInContactSettlingIsThePhaseSettlingTime) {
  const auto samples = step_in_contact(0.05);
  const PhaseOptions options;
  const auto phases = rtm::demo::detect_phases(samples, options);
  ASSERT_EQ(phases.size(), 2u);
  const DemoFigures f = rtm::demo::compute_figures(samples, phases, options);
  EXPECT_TRUE(f.touch_downs.empty());  // in contact from the first sample: no touch-down
  ASSERT_EQ(f.steps.size(), 1u);       // the first phase starts the recording: no step
  const auto& step = f.steps[0];
  EXPECT_EQ(step.phase, 1u);
  EXPECT_NEAR(step.from_N, 10.0, 1e-9);
  EXPECT_NEAR(step.to_N, 20.0, 0.05);  // the reference at the phase start
  EXPECT_NEAR(step.start_s, 1.498, 1e-6);  // within 0.05 N of 20 N on the 20 N/s ramp
  const auto summary = rtm::demo::summarize(samples, phases[1], options);
  ASSERT_TRUE(step.settling_time_s.has_value());
  EXPECT_EQ(step.settling_time_s, summary.settling_time_s);
  // 10 exp(-x / tau) <= 0.5 from 1.5 s, counted from the phase start 2 ms earlier.
  EXPECT_NEAR(*step.settling_time_s, 0.002 + 0.05 * std::log(20.0), 0.0021);
  EXPECT_TRUE(verdict(rtm::demo::evaluate_figures(report_of(samples), options), "settling after a step in contact").ok);
}

TEST(DemoReportFigures, SlowStepInContactIsMissed) {
  const auto samples = step_in_contact(0.2);  // 0.2 ln 20 = 0.6 s
  const DemoFigures f = figures_of(samples);
  ASSERT_EQ(f.steps.size(), 1u);
  ASSERT_TRUE(f.steps[0].settling_time_s.has_value());
  EXPECT_NEAR(*f.steps[0].settling_time_s, 0.002 + 0.2 * std::log(20.0), 0.0021);
  const auto v = verdict(rtm::demo::evaluate_figures(report_of(samples), PhaseOptions{}), "settling after a step in contact");
  EXPECT_FALSE(v.ok);
  EXPECT_NE(v.value.find("10.0 -> 20.0 N"), std::string::npos) << v.value;
}

// Pressing at 10 N until 1 s; the reference ramps to a 3 N pull over [1.0, 1.5] s and holds
// it; the force falls linearly to 0 over [1.0, 1.4] s, then bounces back to 3 N for 10 ms
// `bounces` times (every 50 ms from 1.45 s).
std::vector<Sample> release_run(int bounces, double duration_s = 3.0) {
  return press_run(duration_s, [](double t) { return std::clamp(10 - 26 * (t - 1.0), -3.0, 10.0); },
                   [bounces](double t) {
                     if (t < 1.4) return std::min(10.0, 10 - 25 * (t - 1.0));
                     for (int k = 0; k < bounces; ++k) {
                       const double start = 1.45 + 0.05 * k;
                       if (t >= start && t < start + 0.01) return 3.0;
                     }
                     return 0.0;
                   });
}

TEST(DemoReportFigures, CleanReleaseCountsOneTransition) {
  const auto samples = release_run(0);
  const DemoFigures f = figures_of(samples);
  ASSERT_TRUE(f.release.has_value());
  EXPECT_EQ(f.release->phase, 0u);
  EXPECT_EQ(f.release->transitions, 1);
  EXPECT_TRUE(f.release->lifted);
  EXPECT_DOUBLE_EQ(f.release->axis[2], -1.0);
  EXPECT_NEAR(f.release->start_s, 1.0, 0.0021);
  EXPECT_TRUE(f.touch_downs.empty());  // the pull is no press: nothing touches down
  EXPECT_TRUE(verdict(rtm::demo::evaluate_figures(report_of(samples), PhaseOptions{}), "touch/lift transitions at release").ok);
}

TEST(DemoReportFigures, ReleaseWithOneBounceCountsThreeAndIsMissed) {
  const DemoFigures f = figures_of(release_run(1));
  ASSERT_TRUE(f.release.has_value());
  EXPECT_EQ(f.release->transitions, 3);
  EXPECT_FALSE(verdict(rtm::demo::evaluate_figures(report_of(release_run(1)), PhaseOptions{}),
                       "touch/lift transitions at release").ok);
}

TEST(DemoReportFigures, ReleaseWithFiveCrossingsIsMissed) {
  const auto samples = release_run(2);
  const DemoFigures f = figures_of(samples);
  ASSERT_TRUE(f.release.has_value());
  EXPECT_EQ(f.release->transitions, 5);
  EXPECT_TRUE(f.release->lifted);
  const auto v = verdict(rtm::demo::evaluate_figures(report_of(samples), PhaseOptions{}), "touch/lift transitions at release");
  EXPECT_FALSE(v.ok);
  EXPECT_EQ(v.limit, "<= 2");
  EXPECT_EQ(v.value.rfind("5 (", 0), 0u) << v.value;
  // With a limit of 5 the same release passes.
  FigureLimits loose;
  loose.max_release_transitions = 5;
  EXPECT_TRUE(verdict(rtm::demo::evaluate_figures(report_of(samples), PhaseOptions{}, loose),
                      "touch/lift transitions at release").ok);
}

TEST(DemoReportFigures, ReleaseThatNeverLiftsIsMissed) {
  const auto samples = press_run(3.0, [](double t) { return t < 1.0 ? 10.0 : 5.0; }, [](double t) { return t < 1.0 ? 10.0 : 5.0; });
  const DemoFigures f = figures_of(samples);
  ASSERT_TRUE(f.release.has_value());
  EXPECT_EQ(f.release->phase, 1u);  // the 5 N phase is the last press
  EXPECT_EQ(f.release->transitions, 0);
  EXPECT_FALSE(f.release->lifted);
  const auto v = verdict(rtm::demo::evaluate_figures(report_of(samples), PhaseOptions{}), "touch/lift transitions at release");
  EXPECT_FALSE(v.ok);
  EXPECT_NE(v.value.find("still in contact"), std::string::npos) << v.value;
}

TEST(DemoReportFigures, WatchdogEventsAreMissed) {
  const auto samples = release_run(0);
  EXPECT_TRUE(verdict(rtm::demo::evaluate_figures(report_of(samples, 0), PhaseOptions{}), "watchdog events").ok);
  const auto report = report_of(samples, 3);
  const auto v = verdict(rtm::demo::evaluate_figures(report, PhaseOptions{}), "watchdog events");
  EXPECT_FALSE(v.ok);
  EXPECT_EQ(v.value, "3 (actuator0)");
  EXPECT_EQ(v.limit, "<= 0");
  const auto missed = rtm::demo::missed_figures(report, PhaseOptions{});
  EXPECT_NE(std::find(missed.begin(), missed.end(), "watchdog events: 3 (actuator0) (limit <= 0)"), missed.end());
  // Classified by the demo's witness: the limit applies to the events no host stall explains.
  rtm::demo::FigureLimits classified;
  classified.explained_watchdog_events = 3;
  const auto all_explained = verdict(rtm::demo::evaluate_figures(report, PhaseOptions{}, classified), "watchdog events");
  EXPECT_TRUE(all_explained.ok) << all_explained.value;
  EXPECT_EQ(all_explained.value, "0 not explained by a host stall, of 3 (actuator0)");
  classified.explained_watchdog_events = 1;
  const auto some = verdict(rtm::demo::evaluate_figures(report, PhaseOptions{}, classified), "watchdog events");
  EXPECT_FALSE(some.ok);
  EXPECT_EQ(some.value, "2 not explained by a host stall, of 3 (actuator0)");
  // No component reporting the statistic: not measured, so not ok either.
  auto unknown = report_of(samples);
  unknown.timing.clear();
  EXPECT_FALSE(verdict(rtm::demo::evaluate_figures(unknown, PhaseOptions{}), "watchdog events").ok);
}

// The demo's profile in short: hands off, touch-down under a 10 N press (10 % overshoot),
// 10 -> 20 N in contact, a clean release under a 3 N pull.
std::vector<Sample> good_demo_run() {
  const auto press = [](double t) {
    if (t < 0.5) return 0.0;
    if (t < 2.0) return 10.0;
    if (t < 3.5) return std::min(20.0, 10 + 20 * (t - 2.0));
    return std::max(-3.0, 20 - 46 * (t - 3.5));
  };
  const TouchDownRecording touch{0.10, 0.05};
  return press_run(5.0, press, [touch](double t) {
    if (t < 2.5) return touch.force(t);
    if (t < 3.5) return 20 - 10 * std::exp(-(t - 2.5) / 0.05);
    return std::max(0.0, 20 - 50 * (t - 3.5));
  });
}

TEST(DemoReportFigures, GoodRunMissesNothing) {
  const auto report = report_of(good_demo_run());
  ASSERT_EQ(report.figures.touch_downs.size(), 1u);
  ASSERT_EQ(report.figures.steps.size(), 1u);
  ASSERT_TRUE(report.figures.release.has_value());
  EXPECT_EQ(report.figures.release->transitions, 1);
  const auto verdicts = rtm::demo::evaluate_figures(report, PhaseOptions{});
  EXPECT_EQ(verdicts.size(), 5u);
  for (const auto& v : verdicts) EXPECT_TRUE(v.ok) << v.figure << ": " << v.value;
  const auto missed = rtm::demo::missed_figures(report, PhaseOptions{});
  EXPECT_TRUE(missed.empty()) << missed.front();
}

TEST(DemoReportFigures, BadInputGivesAClearError) {
  const PhaseOptions options;
  EXPECT_THROW(rtm::demo::compute_figures({}, {}, options), ReportError);
  auto samples = good_demo_run();
  const auto phases = rtm::demo::detect_phases(samples, options);
  ASSERT_GE(phases.size(), 2u);
  EXPECT_THROW(rtm::demo::compute_figures(samples, {phases[1], phases[0]}, options), std::invalid_argument);
  EXPECT_THROW(rtm::demo::compute_figures(samples, {{0, samples.size() + 1}}, options), std::invalid_argument);
  EXPECT_THROW(rtm::demo::compute_figures(samples, {{3, 3}}, options), std::invalid_argument);
  PhaseOptions no_band;
  no_band.settle_band_N = 0;
  EXPECT_THROW(rtm::demo::compute_figures(samples, phases, no_band), std::invalid_argument);
  FigureLimits no_level;
  no_level.release_level_N = -0.5;
  EXPECT_THROW(rtm::demo::compute_figures(samples, phases, options, no_level), std::invalid_argument);
  samples[700].measured_N[2] = NAN;
  try {
    rtm::demo::compute_figures(samples, phases, options);
    FAIL() << "no error for a non-finite force";
  } catch (const ReportError& e) {
    EXPECT_NE(std::string(e.what()).find("sample 700 (at 1.4000 s)"), std::string::npos) << e.what();
  }
}

TEST(DemoReportOutput, SummaryPrintsEachFigureWithItsLimitAndVerdict) {
  const auto report = report_of(good_demo_run(), 2);
  FigureLimits limits;
  limits.max_overshoot = 0.05;
  const std::string text = rtm::demo::format_report(report, PhaseOptions{}, limits);
  EXPECT_NE(text.find("Demo figures"), std::string::npos) << text;
  const auto line_of = [&](const std::string& figure) {
    const auto at = text.find("  " + figure);
    return at == std::string::npos ? std::string() : text.substr(at, text.find('\n', at) - at);
  };
  EXPECT_NE(line_of("touch-down overshoot").find("<= 5 %     MISSED 10.0 %"), std::string::npos) << text;
  EXPECT_NE(line_of("settling after touch-down").find("<= 0.30 s  ok"), std::string::npos) << text;
  EXPECT_NE(line_of("settling after a step in contact").find("<= 0.30 s  ok"), std::string::npos) << text;
  EXPECT_NE(line_of("touch/lift transitions at release").find("<= 2       ok     1 ("), std::string::npos) << text;
  EXPECT_NE(line_of("watchdog events").find("<= 0       MISSED 2 (actuator0)"), std::string::npos) << text;
  // The earlier parts are still there.
  EXPECT_NE(text.find("Watchdog events (actuator0): 2"), std::string::npos) << text;
  EXPECT_NE(text.find("contact"), std::string::npos) << text;
}

}  // namespace
