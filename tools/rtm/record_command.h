// SPDX-License-Identifier: Apache-2.0
// rtm record: OutPorts' data into an MCAP file (recorder/recorder.h), and --recover: a
// recording that was not closed (a killed recorder, a file cut short) made whole again.
#pragma once

#include <CLI/App.hpp>

#include <atomic>
#include <string>

#include "browser/browser.h"
#include "recorder/recorder.h"
#include "rtm/orb.h"

namespace rtm::cli {

struct RecordCommand {
  CLI::App* app = nullptr;
  RecordOptions options;
  std::string compression = "zstd";
  std::string recover;  // a damaged recording to make whole at options.output

  void add_to(CLI::App& parent);
  bool parsed() const;
  // --recover needs no naming service: run before one is asked for.
  bool recovers() const { return parsed() && !recover.empty(); }
  // Writes the file; prints each port's count and losses (or JSON). Returns the exit code:
  // 0, or 1 when a port lost data or an unsubscribe failed.
  int record(const Browser& browser, rtm::Orb& orb, bool json, const std::atomic<bool>& interrupted) const;
  int run_recover(bool json) const;
};

}  // namespace rtm::cli
