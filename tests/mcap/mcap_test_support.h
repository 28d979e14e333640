// SPDX-License-Identifier: Apache-2.0
// What the MCAP tests share: a folder that removes itself, and a recording of known messages.
#pragma once

#include <cstdint>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "mcap/reader.h"
#include "mcap/writer.h"
#include "rtm_test/temp_dir.h"

namespace rtm::mcap::test {

using TempDir = rtm_test::TempDir;

inline std::vector<std::uint8_t> file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// A message as the tests write it: the data says which message it is.
inline Message sample_message(std::uint16_t channel, std::uint32_t n, std::uint64_t log_time) {
  Message m;
  m.channel_id = channel;
  m.sequence = n;
  m.log_time = log_time;
  m.publish_time = log_time + 1000 + n % 7;
  m.data.resize(8 + n % 40);
  for (std::size_t i = 0; i < m.data.size(); ++i) m.data[i] = static_cast<std::uint8_t>(n * 31 + i);
  return m;
}

// Writes `count` messages round-robin on `channels` channels, 2 ms apart, and returns them.
inline std::vector<Message> write_sample(const std::string& path, const WriterOptions& options, std::uint32_t count,
                                         std::uint16_t channels = 3) {
  Writer w(path, options);
  const auto schema = w.add_schema("RTM::TimedFloat6", "omgidl", "module RTM { struct TimedFloat6 { float v; }; };");
  for (std::uint16_t c = 0; c < channels; ++c) {
    w.add_channel(schema, "port" + std::to_string(c), "cdr", {{"units", "N"}});
  }
  w.add_metadata("system", {{"components", "sensor0 controller0"}});
  std::vector<Message> written;
  for (std::uint32_t n = 0; n < count; ++n) {
    auto m = sample_message(static_cast<std::uint16_t>(1 + n % channels), n, 1'000'000'000ULL + n * 2'000'000ULL);
    w.write(m.channel_id, m.sequence, m.log_time, m.publish_time, m.data);
    written.push_back(std::move(m));
  }
  w.close();
  return written;
}

}  // namespace rtm::mcap::test
