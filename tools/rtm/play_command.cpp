// SPDX-License-Identifier: Apache-2.0
#include "play_command.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cstdio>

#include "report.h"

namespace rtm::cli {

using nlohmann::json;

void PlayCommand::add_to(CLI::App& parent) {
  app = parent.add_subcommand("play", "put a recording's data into InPorts at the recorded pace (rtm record's files)");
  app->add_option("file", options.input, "the recording (.mcap)")->required();
  app->add_option("--map", options.map,
                  "TOPIC=<component>.<InPort>: where a channel goes (default: where its port fed when recorded)");
  app->add_option("--rate", options.rate, "speed: 2 plays twice as fast")->check(CLI::PositiveNumber)->capture_default_str();
  app->add_flag("--loop", options.loop, "again from the start, until Ctrl-C");
  app->add_option("--from", options.from_s, "start this many seconds after the recording's first datum")
      ->check(CLI::NonNegativeNumber);
  app->add_option("--to", options.to_s, "end this many seconds after the recording's first datum")
      ->check(CLI::PositiveNumber);
  app->add_option("--spin-us", options.spin_us,
                  "wake this many microseconds before each datum's time and spin to it (0: sleep only; a wake-up "
                  "costs tens of microseconds)")
      ->check(CLI::Range(0, 10000))
      ->capture_default_str();
  app->add_flag("--keep-stamps", options.keep_stamps, "put the data with their recorded stamps (default: shifted to now)");
}

int PlayCommand::run(const Browser& browser, bool json_output, const std::atomic<bool>& interrupted) const {
  const auto result = play(
      browser, options, [&] { return interrupted.load(); },
      [&](const std::string& line) {
        if (json_output) return;
        fmt::print(stderr, "rtm play: {}\n", terminal_text(line));
        std::fflush(stderr);
      });
  bool failed = false;
  json routes = json::array();
  for (const auto& r : result.routes) {
    failed = failed || r.failed > 0;
    routes.push_back({{"topic", r.topic}, {"port", r.port}, {"type", r.type}, {"put", r.put}, {"failed", r.failed},
                      {"last_failure", r.last_failure}});
  }
  if (json_output) {
    fmt::print("{}\n", json{{"file", options.input}, {"data", result.data}, {"loops", result.loops},
                            {"seconds", result.seconds}, {"routes", routes}, {"unrouted", result.unrouted},
                            {"lateness_p50_us", result.lateness_p50_ns / 1000.0},
                            {"lateness_p99_us", result.lateness_p99_ns / 1000.0},
                            {"lateness_max_us", result.lateness_max_ns / 1000.0}}
                           .dump());
    return failed ? 1 : 0;
  }
  for (const auto& r : result.routes) {
    fmt::print("{} -> {}: {} put, {} failed{}\n", r.topic, r.port, r.put, r.failed,
               r.failed ? ", the last: " + terminal_text(r.last_failure) : std::string());
  }
  for (const auto& topic : result.unrouted) fmt::print("{}: not played (no InPort to go to)\n", topic);
  fmt::print("{} data in {:.2f} s ({} pass{}), each put after its recorded offset by p50 {:.0f} us, p99 {:.0f} us, "
             "max {:.0f} us\n",
             result.data, result.seconds, result.loops, result.loops == 1 ? "" : "es", result.lateness_p50_ns / 1000.0,
             result.lateness_p99_ns / 1000.0, result.lateness_max_ns / 1000.0);
  return failed ? 1 : 0;
}

}  // namespace rtm::cli
