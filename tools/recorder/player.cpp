// SPDX-License-Identifier: Apache-2.0
#include "recorder/player.h"

#include <fmt/format.h>

#include <algorithm>
#include <map>

#include "browser/values.h"
#include "launcher/system_file.h"
#include "mcap/reader.h"
#include "rt/clock.h"
#include "rt/histogram.h"
#include "rtm/cdr.h"
#include "rtm/data.h"
#include "stamp.h"

namespace rtm::cli {

namespace {

struct Target {
  std::size_t route;  // in PlayResult::routes
  RTM::InPort_var port;
  CORBA::TypeCode_var type;
  bool stamped = false;
};

// --map's "TOPIC=<component>.<InPort>", each topic to one or more ports.
std::map<std::string, std::vector<std::string>> parse_map(const std::vector<std::string>& map) {
  std::map<std::string, std::vector<std::string>> out;
  for (const auto& m : map) {
    const auto eq = m.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == m.size()) {
      throw std::invalid_argument(fmt::format("--map {}: expected TOPIC=<component>.<InPort>", m));
    }
    out[m.substr(0, eq)].push_back(m.substr(eq + 1));
  }
  return out;
}

// Where each topic went when it was recorded: the connections of the recorded system.
std::map<std::string, std::vector<std::string>> recorded_wiring(const mcap::Reader& reader, const std::string& file) {
  std::map<std::string, std::vector<std::string>> out;
  for (const auto& m : reader.metadata()) {
    if (m.name != "rtm.system" || !m.values.contains("yaml")) continue;
    const auto system = SystemFile::parse(m.values.at("yaml"), file + ":rtm.system");
    for (const auto& c : system.connections) out[c.from].push_back(c.to);
  }
  return out;
}

// Sleeps until spin_ns before deadline_ns (CLOCK_MONOTONIC), looking at `stop` at least every
// 100 ms, then spins to the deadline: a wake-up in these VMs takes tens of microseconds, which
// the spin hides at the cost of that much CPU per datum.
bool sleep_until_or_stopped(std::int64_t deadline_ns, std::int64_t spin_ns, const std::function<bool()>& stop) {
  constexpr std::int64_t kSlice = 100'000'000;
  while (true) {
    if (stop()) return false;
    const auto now = rtm::monotonic_ns();
    if (now >= deadline_ns - spin_ns) break;
    rtm::sleep_until_ns(std::min(deadline_ns - spin_ns, now + kSlice));
  }
  while (rtm::monotonic_ns() < deadline_ns) {
  }
  return true;
}

// Each channel's targets, checked as a connection is before anything is put: --map's, else
// the recorded wiring's. The routes go into result, the channels with none into unrouted.
std::map<std::uint16_t, std::vector<Target>> route_channels(const Browser& browser, const mcap::Reader& reader,
                                                            const PlayOptions& options, PlayResult& result,
                                                            const std::function<void(const std::string&)>& progress) {
  const auto mapped = parse_map(options.map);
  for (const auto& [topic, ports] : mapped) {
    if (reader.channel(topic) == nullptr) {
      throw std::invalid_argument(fmt::format("--map: {} has no channel {}", options.input, topic));
    }
  }
  const auto wiring = mapped.empty() ? recorded_wiring(reader, options.input) : mapped;
  std::map<std::uint16_t, std::vector<Target>> targets;
  for (const auto& channel : reader.channels()) {
    const auto to = wiring.find(channel.topic);
    if (to == wiring.end()) {
      result.unrouted.push_back(channel.topic);
      continue;
    }
    const auto* schema = reader.schema(channel.schema_id);
    const std::string recorded_type = schema != nullptr ? schema->name : "<no schema>";
    for (const auto& address : to->second) {
      const auto port = browser.port(PortAddress::parse(address));
      if (port.direction != Direction::in) {
        throw BrowseError(fmt::format("{} is an OutPort; play puts into InPorts", port.address));
      }
      const auto type = rtm::type_name(port.type);
      if (channel.message_encoding != "cdr" || type != recorded_type) {
        throw BrowseError(fmt::format("{}:{} ({}, {}) -> {} ({}): types differ", options.input, channel.topic,
                                      recorded_type, channel.message_encoding, port.address, type));
      }
      targets[channel.id].push_back(Target{result.routes.size(), RTM::InPort::_narrow(port.object),
                                           CORBA::TypeCode::_duplicate(port.type), is_timed_type(port.type)});
      auto& route = result.routes.emplace_back();
      route.topic = channel.topic;
      route.port = port.address;
      route.type = type;
      progress(fmt::format("playing {} into {}", channel.topic, port.address));
    }
  }
  if (result.routes.empty()) {
    throw std::invalid_argument(fmt::format("no channel of {} has an InPort to go to: the recorded wiring names none "
                                            "running; send them with --map TOPIC=<component>.<InPort>",
                                            options.input));
  }
  return targets;
}

}  // namespace

PlayResult play(const Browser& browser, const PlayOptions& options, const std::function<bool()>& stop,
                const std::function<void(const std::string&)>& progress) {
  if (!(options.rate > 0)) throw std::invalid_argument("--rate must be above 0");
  const mcap::Reader reader(options.input);
  const auto& stats = reader.statistics();
  if (stats.message_count == 0) throw std::invalid_argument(fmt::format("{} holds no data", options.input));
  const auto first = stats.message_start_time + static_cast<std::uint64_t>(options.from_s * 1e9);
  const auto last = options.to_s > 0 ? stats.message_start_time + static_cast<std::uint64_t>(options.to_s * 1e9)
                                     : stats.message_end_time;
  if (first > last || first > stats.message_end_time) {
    throw std::invalid_argument(fmt::format("{} has no data from {} s to {} s", options.input, options.from_s,
                                            options.to_s));
  }
  PlayResult result;
  auto targets = route_channels(browser, reader, options, result, progress);

  rtm::LatenessHistogram lateness;
  const std::int64_t start_mono = rtm::monotonic_ns();
  const std::int64_t start_wall = rtm::realtime_ns();
  const auto span = static_cast<double>(last - first);
  const double interval = stats.message_count > 1 ? span / static_cast<double>(stats.message_count - 1) : 0;
  std::vector<std::uint8_t> cdr;
  bool stopped = false;
  do {
    // This pass's offset from the start: one recording's span and one interval per pass.
    const auto pass = static_cast<double>(result.loops) * (span + interval);
    reader.read_messages({first, last}, [&](const mcap::Message& m) {
      const auto it = targets.find(m.channel_id);
      if (stopped || it == targets.end()) return;
      const auto offset = static_cast<std::int64_t>((pass + static_cast<double>(m.log_time - first)) / options.rate);
      const std::int64_t due = start_mono + offset;
      for (auto& t : it->second) {
        cdr = m.data;
        if (t.stamped && !options.keep_stamps) restamp(cdr, static_cast<std::uint64_t>(start_wall + offset));
        CORBA::Any value;
        try {
          value = rtm::from_cdr(t.type, cdr);
        } catch (const std::invalid_argument& e) {
          auto& route = result.routes[t.route];
          ++route.failed;
          route.last_failure = e.what();
          continue;
        }
        if (!sleep_until_or_stopped(due, options.spin_us * 1000, stop)) {
          stopped = true;
          return;
        }
        lateness.record(rtm::monotonic_ns() - due);
        auto& route = result.routes[t.route];
        try {
          t.port->put(value);
          ++route.put;
        } catch (const CORBA::Exception& e) {
          ++route.failed;
          route.last_failure = e._name();
        }
      }
      ++result.data;
    });
    ++result.loops;
  } while (options.loop && !stopped && !stop());

  result.seconds = static_cast<double>(rtm::monotonic_ns() - start_mono) / 1e9;
  result.lateness_p50_ns = lateness.percentile_ns(0.5);
  result.lateness_p99_ns = lateness.percentile_ns(0.99);
  result.lateness_max_ns = lateness.max_ns();
  return result;
}

}  // namespace rtm::cli
