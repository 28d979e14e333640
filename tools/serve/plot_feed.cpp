// SPDX-License-Identifier: Apache-2.0
#include "serve/plot_feed.h"

#include "browser/watch_port.h"
#include "rtm/data.h"
#include "rtm/orb.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include <cmath>

namespace rtm::cli {

namespace {

// How often the publisher is asked what it dropped for a plot (one remote call).
constexpr std::chrono::seconds kPublisherLook{1};

// A value as JSON: 7 significant digits (the ports' floats hold no more), null when no number.
void append_number(std::string& out, double v) {
  if (!std::isfinite(v)) {
    out += "null";
    return;
  }
  fmt::format_to(std::back_inserter(out), "{:.7g}", v);
}

}  // namespace

std::string plot_entry(const std::string& type, const std::vector<Sample>& samples, std::uint64_t sent,
                       std::uint64_t lost, long long received_ns) {
  std::string out = "{\"type\":" + nlohmann::json(type).dump() + ",\"t\":[";
  bool stamped = true;
  std::size_t columns = 0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const long long ns = samples[i].time_ns != 0 ? samples[i].time_ns : received_ns;
    stamped = stamped && samples[i].time_ns != 0;
    columns = std::max(columns, samples[i].values.size());
    if (i) out += ',';
    // Seconds with the nanoseconds kept as digits (a double of seconds since 1970 keeps
    // about 0.2 us): "1795445401.123456789".
    fmt::format_to(std::back_inserter(out), "{}.{:09}", ns / 1'000'000'000, ns % 1'000'000'000);
  }
  out += "],\"v\":[";
  for (std::size_t c = 0; c < columns; ++c) {
    if (c) out += ',';
    out += '[';
    for (std::size_t i = 0; i < samples.size(); ++i) {
      if (i) out += ',';
      append_number(out, c < samples[i].values.size() ? samples[i].values[c] : NAN);
    }
    out += ']';
  }
  fmt::format_to(std::back_inserter(out), "],\"sent\":{},\"lost\":{},\"stamped\":{}", sent, lost, stamped);
  if (!samples.empty()) {
    const Sample& last = samples.back();
    const long long ns = last.time_ns != 0 ? last.time_ns : received_ns;
    fmt::format_to(std::back_inserter(out), ",\"time\":{{\"sec\":{},\"nsec\":{}}},\"values\":[", ns / 1'000'000'000,
                   ns % 1'000'000'000);
    for (std::size_t c = 0; c < last.values.size(); ++c) {
      if (c) out += ',';
      append_number(out, last.values[c]);
    }
    out += ']';
  }
  out += '}';
  return out;
}

PlotSubscription::PlotSubscription(const Browser& browser, rtm::Orb& orb, const std::string& address) {
  const ResolvedPort port = browser.port(PortAddress::parse(address));
  if (port.direction != Direction::out)
    throw BrowseError(port.address + " is an InPort; only OutPorts have data to plot");
  type_ = rtm::type_name(port.type);
  subscription_ = std::make_unique<WatchSubscription>(orb, port.object, port.type, port.address,
                                                      fmt::format("{}{}", kPlotOwnerPrefix, ::getpid()), kPlotQueue,
                                                      "the plot's subscription");
}

PlotSubscription::~PlotSubscription() = default;

std::string PlotSubscription::take() {
  std::lock_guard lock(take_mu_);
  arrived_.clear();
  samples_.clear();
  WatchPort& port = subscription_->port();
  port.drain(arrived_, std::chrono::milliseconds(0));
  const long long now_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
                               std::chrono::system_clock::now().time_since_epoch()).count();
  for (const CORBA::Any& a : arrived_) samples_.push_back(to_sample(a));
  sent_ += samples_.size();
  const auto now = std::chrono::steady_clock::now();
  if (now - asked_publisher_ >= kPublisherLook) {
    asked_publisher_ = now;
    publisher_lost_ = subscription_->publisher_dropped().value_or(publisher_lost_);  // else asked again a second later
  }
  return plot_entry(type_, samples_, sent_, port.overflowed() + port.late() + publisher_lost_, now_ns);
}

std::shared_ptr<PlotSubscription> PagePlots::take(const std::string& page, const std::string& address,
                                                  const std::function<std::shared_ptr<PlotSubscription>()>& make) {
  if (page.empty()) return make();
  {
    std::lock_guard lock(mu_);
    for (auto p = pages_.begin(); p != pages_.end();) {
      std::erase_if(p->second, [](const auto& entry) { return entry.second.expired(); });
      p = p->second.empty() ? pages_.erase(p) : std::next(p);
    }
    if (auto kept = pages_[page][address].lock()) return kept;
  }
  auto made = make();  // remote calls: not under the lock
  std::lock_guard lock(mu_);
  pages_[page][address] = made;
  return made;
}

}  // namespace rtm::cli
