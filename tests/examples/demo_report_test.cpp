// rtm-demo-report's arithmetic on synthetic recordings whose answers are known in closed form.
#include "demo_report.h"

#include <gtest/gtest.h>
#include <unistd.h>

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

}  // namespace
