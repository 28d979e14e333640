// SPDX-License-Identifier: Apache-2.0
// `rtm watch`: subscribes a temporary InPort (WatchPort) to an OutPort and shows its data
// live: a refreshing line on a terminal, one line per datum otherwise, JSON lines with
// --json, and every datum in a CSV file with --csv (columns named after the port's elements).
#pragma once

#include "browser/browser.h"

#include "rtm/orb.h"

#include <atomic>
#include <string>

namespace rtm::cli {

struct WatchOptions {
  double rate_hz = 10;    // refresh rate of the live line
  std::string csv_path;   // "" = no CSV
  long count = 0;         // stop after this many data (0 = no limit)
  double duration_s = 0;  // stop after this long (0 = no limit)
  bool json = false;
};

// Runs until interrupted becomes true or a limit is reached; returns the exit status (0, or 1
// when the unsubscribe at the end failed). Throws BrowseError when the port is not an
// OutPort or refuses the subscription, std::runtime_error when the CSV cannot be written.
int watch(const Browser& browser, rtm::Orb& orb, const std::string& address, const WatchOptions& options,
          const std::atomic<bool>& interrupted);

}  // namespace rtm::cli
