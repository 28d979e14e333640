// SPDX-License-Identifier: Apache-2.0
// A recording as rtm serve shows it: its channels with their types, elements and units, and a
// channel's data decoded (with the TypeCode the recording keeps) into plain numbers.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "browser/browser.h"
#include "browser/values.h"

namespace rtm::cli {

struct RecordedChannel {
  std::string topic;
  std::string type;
  std::vector<ElementInfo> elements;  // as the port described them when recorded
  std::uint64_t count = 0;
};

struct RecordingInfo {
  std::string file;
  std::uint64_t start_ns = 0, end_ns = 0;  // the first and last datum's log time
  std::vector<RecordedChannel> channels;
  std::string system_yaml;  // the recorded system, "" when the file has none
};

// Throws mcap::FormatError (a file that is no whole recording: recover it first) or
// std::system_error (cannot be opened).
RecordingInfo describe_recording(const std::string& file);

struct RecordedSeries {
  std::string type;
  std::vector<Sample> samples;  // every k-th datum of the channel, k the smallest that keeps
                                // at most max_samples
  std::uint64_t total = 0;      // data of the channel in the file
};

// One channel's data in log-time order. Throws std::invalid_argument for a topic the file
// does not have, or a channel with no TypeCode (not written by rtm record).
RecordedSeries recorded_series(const std::string& file, const std::string& topic, std::size_t max_samples);

}  // namespace rtm::cli
