// SPDX-License-Identifier: Apache-2.0
// `rtm play`: a recording's data put into InPorts at the recorded pace.
//
// Each channel goes to the InPorts its port fed when it was recorded (the wiring in the
// recording's "rtm.system" metadata), or where --map sends it ("sensor0.out0=controller0.in1").
// Before anything is put each target is checked as a connection is: an InPort of the channel's
// type ("run.mcap:sensor0.out0 (RTM::TimedFloat6) -> c.in1 (RTM::TimedFloat3): types differ").
//
// Datum k is put at start + (log_time_k - log_time_0) / rate on CLOCK_MONOTONIC, each
// deadline computed from the start, never from the previous put: the pace does not drift, and
// a late put does not delay the ones after it. A datum that starts with its stamp is
// restamped by the same shift (its intervals kept, its age now), unless keep_stamps.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "browser/browser.h"

namespace rtm::cli {

struct PlayOptions {
  std::string input;                // the .mcap file
  std::vector<std::string> map;     // "TOPIC=<component>.<InPort>", in place of the recorded wiring
  double rate = 1.0;                // 2: twice as fast
  bool loop = false;                // again from the start until stopped
  double from_s = 0;                // seconds after the recording's first datum
  double to_s = 0;                  // ... and up to (0: its end)
  bool keep_stamps = false;         // put the data with their recorded stamps
  std::int64_t spin_us = 150;       // wake this early and spin to each datum's time (0: sleep only)
};

struct PlayedRoute {
  std::string topic;
  std::string port;  // "<component>.<InPort>"
  std::string type;
  std::uint64_t put = 0;
  std::uint64_t failed = 0;
  std::string last_failure;
};

struct PlayResult {
  std::vector<PlayedRoute> routes;
  std::vector<std::string> unrouted;  // channels with no InPort to go to
  std::uint64_t data = 0;             // data put (to one or more ports each)
  std::uint64_t loops = 0;
  double seconds = 0;
  // How late each datum was put after its recorded offset (ns).
  std::int64_t lateness_p50_ns = 0, lateness_p99_ns = 0, lateness_max_ns = 0;
};

// Plays until the end (or forever with loop) or `stop` returns true. Throws mcap::FormatError
// for a file it cannot read, BrowseError for a target that is not an InPort of the channel's
// type, std::invalid_argument for a bad --map or an empty range.
PlayResult play(const Browser& browser, const PlayOptions& options, const std::function<bool()>& stop,
                const std::function<void(const std::string&)>& progress);

}  // namespace rtm::cli
