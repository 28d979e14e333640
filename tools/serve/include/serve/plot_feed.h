// SPDX-License-Identifier: Apache-2.0
// What rtm serve's plots' stream sends: every datum of each plotted OutPort, not a sample of it.
//
// Each plotted port gets an InPort of this server (browser/watch_port.h, what `rtm watch`
// subscribes: a bounded FIFO, fed from the publisher's shared-memory ring on this host, else
// by a call per datum), subscribed for as long as the page plots it. Every event takes what
// arrived since the last one and sends it as columns: the stamps, then one column per value.
// What is lost is counted where it is lost (the server's queue full, a datum out of order, the
// publisher's own drops for this subscriber) and sent with the count of data sent, so that the
// page can say both, and a test can compare them with what it drew.
#pragma once

#include "browser/browser.h"
#include "browser/values.h"
#include "launcher/running_system.h"

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

namespace rtm {
class Orb;
}

namespace rtm::cli {

class WatchSubscription;

// At most this many ports in one plots' stream (the page offers ten).
inline constexpr std::size_t kPlotPortsMax = 10;
// A plotted port's queue between two events: 16 s of a 500 Hz port. Beyond, the oldest are
// lost, and counted.
inline constexpr std::size_t kPlotQueue = 8192;

// One port's share of a plots' event, as JSON text:
//   {"type": "RTM::TimedFloat6", "t": [s, ...], "v": [[column 0], [column 1], ...],
//    "sent": n, "lost": n, "stamped": true,
//    "time": {"sec": s, "nsec": ns}, "values": [...]}     (the last datum, when any arrived)
// t: each datum's stamp in seconds since the epoch (its `tm`; for a datum without one, when the
// server took it: then "stamped": false); v: one column per value, in the datum's order. sent:
// the data sent on this stream so far, these included; lost: the data the port wrote for this
// stream that never reached it. Numbers that are no number (NaN, infinity) are sent as null.
// received_ns: when the server took the data (stamps the unstamped ones).
std::string plot_entry(const std::string& type, const std::vector<Sample>& samples, std::uint64_t sent,
                       std::uint64_t lost, long long received_ns);

// A plotted OutPort: the server's InPort subscribed to it while this lives.
class PlotSubscription {
 public:
  // Resolves address, makes and subscribes the InPort (owner "rtm-serve-<pid>"). Throws
  // BrowseError (an InPort, refused, no ORB to serve it) or what Browser::port throws.
  PlotSubscription(const Browser& browser, rtm::Orb& orb, const std::string& address);
  ~PlotSubscription();  // unsubscribes (a failure ignored: the publisher may be gone) and deactivates

  // What arrived since the last call, as plot_entry's text. A page's new stream takes over its
  // old stream's subscriptions (nothing written in between is missed), and the old one may
  // still be taking while it ends: calls are serialised.
  std::string take();

 private:
  std::mutex take_mu_;
  std::string type_;
  std::unique_ptr<WatchSubscription> subscription_;  // unsubscribed when the plot goes
  std::uint64_t sent_ = 0;
  std::uint64_t publisher_lost_ = 0;
  std::chrono::steady_clock::time_point asked_publisher_{};
  std::vector<CORBA::Any> arrived_;
  std::vector<Sample> samples_;
};

// Each page's plot subscriptions by port. A page's stream replaced by its next (a plot added or
// removed) hands over the subscriptions of the ports both plot: their data keep coming, counted
// once, none missed in between. Held by the streams (weak here): one no stream holds is gone,
// and its entry with it, whatever page ids clients make up.
class PagePlots {
 public:
  // page's subscription of address: the one a stream of the page holds, else make()'s (which
  // may throw). Without a page id no stream shares one.
  std::shared_ptr<PlotSubscription> take(const std::string& page, const std::string& address,
                                         const std::function<std::shared_ptr<PlotSubscription>()>& make);

 private:
  std::mutex mu_;
  std::map<std::string, std::map<std::string, std::weak_ptr<PlotSubscription>>> pages_;
};

// The prefix of the owner name of this server's plot InPorts: their subscriptions are the
// page's, not the system's (a saved system file leaves them out).
inline constexpr const char* kPlotOwnerPrefix = "rtm-serve-";
static_assert(std::string_view(kPlotOwnerPrefix) == kToolSubscriberPrefixes[0],
              "a saved system file leaves out the plots' subscriptions by this prefix");

}  // namespace rtm::cli
