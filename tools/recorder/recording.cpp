// SPDX-License-Identifier: Apache-2.0
#include "recorder/recording.h"

#include <fmt/format.h>

#include <sstream>

#include "mcap/reader.h"
#include "rtm/cdr.h"
#include "rtm/data.h"

namespace rtm::cli {

namespace {

std::vector<std::string> split(const std::string& text) {
  std::vector<std::string> out;
  if (text.empty()) return out;
  std::stringstream in(text);
  for (std::string part; std::getline(in, part, ',');) out.push_back(part);
  return out;
}

std::string value_of(const mcap::KeyValues& kv, const std::string& key) {
  const auto it = kv.find(key);
  return it == kv.end() ? std::string() : it->second;
}

}  // namespace

RecordingInfo describe_recording(const std::string& file) {
  const mcap::Reader reader(file);
  RecordingInfo info;
  info.file = file;
  info.start_ns = reader.statistics().message_start_time;
  info.end_ns = reader.statistics().message_end_time;
  for (const auto& c : reader.channels()) {
    RecordedChannel channel;
    channel.topic = c.topic;
    const auto* schema = reader.schema(c.schema_id);
    channel.type = schema != nullptr ? schema->name : value_of(c.metadata, "type");
    const auto names = split(value_of(c.metadata, "elements"));
    const auto units = split(value_of(c.metadata, "units"));
    for (std::size_t i = 0; i < names.size(); ++i) channel.elements.push_back({names[i], i < units.size() ? units[i] : ""});
    const auto count = reader.statistics().channel_message_counts.find(c.id);
    channel.count = count == reader.statistics().channel_message_counts.end() ? 0 : count->second;
    info.channels.push_back(std::move(channel));
  }
  for (const auto& m : reader.metadata())
    if (m.name == "rtm.system") info.system_yaml = value_of(m.values, "yaml");
  return info;
}

RecordedSeries recorded_series(const std::string& file, const std::string& topic, std::size_t max_samples) {
  const mcap::Reader reader(file);
  const auto* channel = reader.channel(topic);
  if (channel == nullptr) throw std::invalid_argument(fmt::format("{} has no channel {}", file, topic));
  const auto text = value_of(channel->metadata, "typecode");
  if (text.empty()) throw std::invalid_argument(fmt::format("{}: channel {} has no typecode (not written by rtm record)", file, topic));
  CORBA::TypeCode_var type = rtm::type_code_from_text(text);
  RecordedSeries series;
  series.type = rtm::type_name(type);
  const auto counts = reader.statistics().channel_message_counts;
  series.total = counts.contains(channel->id) ? counts.at(channel->id) : 0;
  const std::uint64_t stride = max_samples == 0 ? 1 : std::max<std::uint64_t>(1, (series.total + max_samples - 1) / max_samples);
  std::uint64_t n = 0;
  reader.read_messages({}, [&](const mcap::Message& m) {
    if (m.channel_id != channel->id) return;
    if (n++ % stride != 0) return;
    try {
      auto sample = to_sample(rtm::from_cdr(type, m.data));
      if (sample.time_ns == 0) sample.time_ns = static_cast<long long>(m.log_time);
      series.samples.push_back(std::move(sample));
    } catch (const std::invalid_argument&) {
      // A datum that is not a whole value of its type: left out of the plot, counted as not shown.
    }
  });
  return series;
}

}  // namespace rtm::cli
