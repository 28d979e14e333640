// SPDX-License-Identifier: Apache-2.0
#include "record_command.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>

#include "mcap/reader.h"
#include "report.h"

namespace rtm::cli {

using nlohmann::json;

void RecordCommand::add_to(CLI::App& parent) {
  app = parent.add_subcommand("record", "record OutPorts' data into an MCAP file (until Ctrl-C, --duration or --count)");
  app->add_option("ports", options.ports, "<component>.<OutPort>...");
  app->add_flag("--all", options.all, "every OutPort of every component running");
  app->add_option("-o,--output", options.output, "the recording (.mcap)")->required();
  app->add_flag("--force", options.overwrite, "overwrite the output if it exists");
  app->add_option("--compression", compression, "chunk compression")
      ->check(CLI::IsMember({"zstd", "lz4", "none"}))
      ->capture_default_str();
  app->add_option("--duration", options.duration_s, "stop after this many seconds")->check(CLI::PositiveNumber);
  app->add_option("--count", options.count, "stop after this many data in all")->check(CLI::PositiveNumber);
  app->add_option("--recover", recover,
                  "instead: read a recording that was not closed (killed, cut short) up to its last whole chunk and "
                  "write it whole at -o");
}

bool RecordCommand::parsed() const { return app != nullptr && app->parsed(); }

int RecordCommand::record(const Browser& browser, rtm::Orb& orb, bool json_output,
                          const std::atomic<bool>& interrupted) const {
  RecordOptions chosen = options;
  chosen.compression = mcap::compression_from_name(compression == "none" ? "" : compression);
  const auto result = rtm::cli::record(
      browser, orb, chosen, [&] { return interrupted.load(); },
      [&](const std::string& line) {
        if (json_output) return;
        fmt::print(stderr, "rtm record: {}\n", terminal_text(line));
        std::fflush(stderr);
      });
  bool lost = false;
  json ports = json::array();
  for (const auto& p : result.ports) {
    lost = lost || p.dropped_by_publisher > 0 || p.dropped_by_recorder > 0 || p.wrong_type > 0;
    ports.push_back({{"port", p.address}, {"type", p.type}, {"path", p.path}, {"recorded", p.recorded},
                     {"dropped_by_publisher", p.dropped_by_publisher}, {"dropped_by_recorder", p.dropped_by_recorder},
                     {"late", p.late}, {"wrong_type", p.wrong_type}});
  }
  if (json_output) {
    fmt::print("{}\n", json{{"file", options.output}, {"bytes", result.bytes}, {"seconds", result.seconds},
                            {"ports", ports}, {"left_out", result.left_out}}
                           .dump());
  } else {
    for (const auto& p : result.ports) {
      fmt::print("{}: {} recorded through {}, dropped {} by the publisher, {} by the recorder, {} late, {} of a wrong type\n",
                 p.address, p.recorded, p.path, p.dropped_by_publisher, p.dropped_by_recorder, p.late, p.wrong_type);
    }
    for (const auto& l : result.left_out) fmt::print("not in the system metadata: {}\n", terminal_text(l));
    fmt::print("{}: {} bytes in {:.1f} s\n", options.output, result.bytes, result.seconds);
  }
  return lost ? 1 : 0;
}

int RecordCommand::run_recover(bool json_output) const {
  if (!options.overwrite && std::filesystem::exists(options.output)) {
    throw std::invalid_argument(fmt::format("{} exists (--force to overwrite it)", options.output));
  }
  const auto found = mcap::recover_to(recover, options.output);
  if (json_output) {
    fmt::print("{}\n", json{{"file", options.output}, {"messages", found.message_count}, {"chunks", found.chunk_count},
                            {"complete", found.complete}, {"stopped_because", found.stopped_because}}
                           .dump());
  } else {
    fmt::print("{}: {} messages in {} chunks recovered from {}{}\n", options.output, found.message_count,
               found.chunk_count, recover,
               found.complete ? " (its data were whole)" : "; reading stopped: " + terminal_text(found.stopped_because));
  }
  return 0;
}

}  // namespace rtm::cli
