// SPDX-License-Identifier: Apache-2.0
// Figures of the `rtm` tool, measured with the real binary against real processes:
//   1. `rtm ls` (and `rtm ls -l`) of N components: wall time per call, p50 and max;
//   2. `rtm watch` on a 500 Hz stream: data received vs written, drops.
// Usage: rtm_cli_bench [--components N] [--calls N] [--watch-seconds S]
#include "rtm_test/run_command.h"

#include "rtm_test/child_process.h"
#include "rtm_test/omni_names.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <memory>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

void report(const char* what, std::vector<double> ms) {
  std::sort(ms.begin(), ms.end());
  fmt::print("{:<28} calls {:>3}  p50 {:7.2f} ms  max {:7.2f} ms\n", what, ms.size(),
             ms[ms.size() / 2], ms.back());
}

}  // namespace

int main(int argc, char** argv) {
  int components = 50, calls = 20;
  double watch_seconds = 10;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--components")) components = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--calls")) calls = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--watch-seconds")) watch_seconds = std::atof(argv[i + 1]);
  }
  rtm_test::OmniNames names;
  std::vector<std::unique_ptr<rtm_test::ChildProcess>> procs;
  rtm_test::ChildProcess::Options quiet;
  quiet.echo_output = false;
  for (int i = 0; i < components; ++i) {
    procs.push_back(std::make_unique<rtm_test::ChildProcess>(
        std::vector<std::string>{TALKER_PATH, "--name", fmt::format("c{:02}", i), "--naming",
                                 names.address()},
        quiet));
  }
  for (auto& p : procs) p->wait_until_bound(std::chrono::seconds(30));
  const std::vector<std::string> rtm{RTM_CLI_PATH, "--naming", names.address()};
  auto run = [&](std::vector<std::string> args) {
    args.insert(args.begin(), rtm.begin(), rtm.end());
    return rtm_test::run_command(args);
  };

  fmt::print("rtm ls with {} components bound (each its own process)\n", components);
  for (const auto& variant : {std::vector<std::string>{"ls"}, std::vector<std::string>{"ls", "-l"},
                              std::vector<std::string>{"--json", "ls", "-l"}}) {
    std::vector<double> ms;
    for (int i = 0; i < calls; ++i) {
      auto t0 = Clock::now();
      auto r = run(variant);
      ms.push_back(ms_since(t0));
      if (r.exit_code != 0) {
        fmt::print(stderr, "rtm failed: {}\n", r.err);
        return 1;
      }
    }
    std::string label = "rtm";
    for (const auto& w : variant) label += " " + w;
    report(label.c_str(), ms);
  }

  // 500 Hz stream: the first component at 2 ms.
  if (run({"on", "c00"}).exit_code != 0) return 1;
  auto written = [&] {
    auto j = json::parse(run({"--json", "cat", "c00"}).out);
    for (const auto& p : j["ports"]) {
      if (p["name"] == "force") return p["counters"]["accepted"].get<unsigned long long>();
    }
    return 0ull;
  };
  const auto before = written();
  auto w = run({"--json", "watch", "c00.force", "--duration", fmt::format("{}", watch_seconds)});
  const auto after = written();
  json summary;
  std::size_t lines = 0;
  for (std::size_t pos = 0, next; pos < w.out.size(); pos = next + 1) {
    next = w.out.find('\n', pos);
    if (next == std::string::npos) next = w.out.size();
    auto line = w.out.substr(pos, next - pos);
    if (line.empty()) continue;
    auto j = json::parse(line);
    if (j.contains("summary")) summary = j["summary"]; else ++lines;
  }
  fmt::print("rtm watch of a 500 Hz port for {:.0f} s: received {} ({:.1f} Hz), written meanwhile "
             "{} (incl. the watch's start/stop), dropped by publisher {}, by display {}\n",
             watch_seconds, summary["received"].get<unsigned long long>(),
             summary["received"].get<double>() / summary["seconds"].get<double>(), after - before,
             summary["dropped_publisher"].get<unsigned long long>(),
             summary["dropped_display"].get<unsigned long long>());
  return 0;
}
