// SPDX-License-Identifier: Apache-2.0
#include "serve/serve.h"

#include "browser/json.h"
#include "serve/plot_feed.h"
#include "serve/serve_gate.h"
#include "serve/stream_slots.h"
#include "serve/system_feed.h"
#include "launcher/running_system.h"
#include "launcher/system_file.h"
#include "recorder/recording.h"
#include "browser/values.h"

#include "rtm/data.h"
#include "rtm/orb.h"

#include <fmt/format.h>
#include <httplib.h>
#include <nlohmann/json.hpp>
#include <sys/random.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string_view>
#include <system_error>
#include <thread>

namespace rtm::cli {

// The page, its script and its style, embedded at build time from tools/serve/web/
// (web_page.cpp.in).
extern const char* const kWebPage;
extern const char* const kWebScript;
extern const char* const kWebStyle;

namespace {

using nlohmann::json;

// How often the event streams' system is polled (for every page at once): a component's
// state, timing and wiring reach the page within this.
constexpr std::chrono::milliseconds kSystemPeriod{500};
// An event stream writes at least this often: a closed page is only noticed when a write to it
// fails (the second after it closed), and until then its stream holds its slot.
constexpr std::chrono::seconds kKeepAlive{1};
// How often a waiting event stream looks whether a newer stream of its page replaced it.
constexpr std::chrono::milliseconds kReplacedLook{100};
// Streams open at once, all pages together (each page holds at most one of each kind: the
// system's, and its plots' when it plots). Each runs on a thread of its own, never on the
// workers that answer the API; beyond this a stream is refused with 503.
constexpr std::size_t kStreamsInAll = 32;

// What the page may load and do (every answer carries it): its own script and style only, no
// script or style written into the page, no plugin, frame, form or base, and no framing.
// default-src stays 'self' with every other kind of load closed one by one.
constexpr const char* kContentSecurityPolicy =
    "default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data:; connect-src 'self'; "
    "font-src 'none'; media-src 'none'; object-src 'none'; frame-src 'none'; worker-src 'none'; "
    "manifest-src 'none'; base-uri 'none'; form-action 'none'; frame-ancestors 'none'";
// A plots' stream sends what its ports wrote this often (25 events a second, each with every
// datum that arrived since the one before).
constexpr std::chrono::milliseconds kPlotPeriod{40};

// "a.out0,b.out1" -> its addresses, empty ones left out.
std::vector<std::string> split_ports(const std::string& ports) {
  std::vector<std::string> out;
  for (std::size_t begin = 0; begin < ports.size();) {
    const std::size_t comma = std::min(ports.find(',', begin), ports.size());
    if (comma > begin) out.push_back(ports.substr(begin, comma - begin));
    begin = comma + 1;
  }
  return out;
}

// One page's plots: a subscription per port (or why there is none), made when the stream
// starts and undone when it ends, and when the next event is due.
struct PlotStream {
  std::vector<std::string> ports;
  std::vector<std::shared_ptr<PlotSubscription>> subscriptions;  // one per port; nullptr: errors[i]
  std::vector<std::string> errors;
  std::chrono::steady_clock::time_point next = std::chrono::steady_clock::now();
};

std::string random_token() {
  unsigned char bytes[24];
  std::size_t got = 0;
  while (got < sizeof bytes) {
    const ssize_t n = ::getrandom(bytes + got, sizeof bytes - got, 0);
    if (n < 0) throw std::runtime_error("no randomness for the access token");
    got += static_cast<std::size_t>(n);
  }
  std::string hex;
  for (unsigned char b : bytes) hex += fmt::format("{:02x}", b);
  return hex;
}

bool same_secret(const std::string& a, const std::string& b) {
  if (a.size() != b.size()) return false;
  unsigned char diff = 0;  // the same time wherever they differ
  for (std::size_t i = 0; i < a.size(); ++i) diff |= static_cast<unsigned char>(a[i] ^ b[i]);
  return diff == 0;
}

// A recording on this machine (rtm record's file), asked of with `read`: a path that is no
// file, or a file that is no whole recording, is a bad request (400) with the reader's sentence.
template <typename Read>
json from_recording(const std::string& file, Read&& read) {
  if (file.empty()) throw std::invalid_argument("file: which recording (a path on the server's machine)");
  std::error_code error;
  if (!std::filesystem::is_regular_file(file, error)) throw std::invalid_argument(file + " is not a file");
  try {
    return read(file);
  } catch (const std::runtime_error& e) {  // mcap::FormatError, std::system_error
    throw std::invalid_argument(e.what());
  }
}

// Its channels; their data are read only when one is plotted.
json recording(const std::string& file) {
  return from_recording(file, [](const std::string& f) {
    const auto info = describe_recording(f);
    json channels = json::array();
    for (const auto& c : info.channels) {
      json elements = json::array();
      for (const auto& e : c.elements) elements.push_back({{"name", e.name}, {"unit", e.unit}});
      channels.push_back({{"topic", c.topic}, {"type", c.type}, {"count", c.count}, {"elements", elements}});
    }
    return json{{"file", info.file}, {"start_ns", info.start_ns}, {"end_ns", info.end_ns}, {"channels", channels},
                {"system", info.system_yaml}};
  });
}

// One channel whole, as a plot's stream sends a port's data, at most kRecordedPoints data.
json recording_values(const std::string& file, const std::string& topic) {
  constexpr std::size_t kRecordedPoints = 5000;
  return from_recording(file, [&](const std::string& f) {
    const auto series = recorded_series(f, topic, kRecordedPoints);
    json j = json::parse(plot_entry(series.type, series.samples, series.total, 0, 0));
    j["total"] = series.total;
    j["shown"] = series.samples.size();
    return j;
  });
}

bool is_loopback(const std::string& host) { return host == "127.0.0.1" || host == "::1" || host == "localhost"; }

void reply(httplib::Response& res, int status, const json& body) {
  res.status = status;
  res.set_content(body.dump(), "application/json");
}

void refuse(httplib::Response& res, int status, const std::string& why) { reply(res, status, json{{"error", why}}); }

// Runs one API action that answers itself (a stream), turning each kind of failure into the
// status and the sentence `rtm` would print for it.
void decide(httplib::Response& res, const std::function<void()>& action) {
  try {
    action();
  } catch (const StreamsFull& e) {
    refuse(res, 503, e.what());
  } catch (const BrowseError& e) {
    refuse(res, 409, e.what());
  } catch (const ValueError& e) {
    refuse(res, 400, e.what());
  } catch (const SystemFileError& e) {
    refuse(res, 400, e.what());
  } catch (const std::invalid_argument& e) {
    refuse(res, 400, e.what());
  } catch (const json::exception& e) {
    refuse(res, 400, std::string("the request's body is no JSON of the expected shape: ") + e.what());
  } catch (const CORBA::Exception& e) {
    refuse(res, 502, failure_text(e));
  } catch (const std::exception& e) {
    refuse(res, 500, e.what());
  }
}

// Runs one API action: its JSON with 200, or a failure as decide() maps it.
void answer(httplib::Response& res, const std::function<json()>& action) {
  decide(res, [&] { reply(res, 200, action()); });
}

// Recordings need nothing of the running system: their routes stand apart.
void add_recording_routes(httplib::Server& server) {
  server.Get("/api/recording", [](const httplib::Request& req, httplib::Response& res) {
    answer(res, [&] { return recording(req.get_param_value("file")); });
  });
  server.Get("/api/recording/values", [](const httplib::Request& req, httplib::Response& res) {
    answer(res, [&] { return recording_values(req.get_param_value("file"), req.get_param_value("topic")); });
  });
}

// A component the API is asked about or to act on, by name: refused (std::invalid_argument,
// answered 400 with the naming rule's sentence) when the name breaks the rule. Such an entry
// was bound by hand, not by an RTM component; nothing is done to it through this server.
const std::string& addressed(const std::string& name) {
  check_name(name);
  return name;
}

// A port address the API is given ("component.port"), its component named by the rule as
// addressed() has it: the page names components by name alone, never "host/name".
PortAddress addressed_port(const std::string& text) {
  PortAddress a = PortAddress::parse(text);
  addressed(a.component);
  return a;
}

// What applying a system file would do, doing nothing: each connection (made already, to
// make, or why it cannot be: the messages of `rtm connect`), each activation (the
// component's state now), and the file's components that are not running.
json preview_system_file(const Browser& browser, const std::string& yaml) {
  const SystemFile file = SystemFile::parse(yaml, "posted-system-file.yaml");
  std::map<std::string, std::string> state;                // component -> state now
  std::map<std::string, std::vector<std::string>> peers;  // "<component>.<OutPort>" -> InPorts
  for (const auto& c : browser.list("", Browser::Detail::wiring)) {
    state[c.path.name] = c.liveness == Liveness::alive ? c.state : "dead";
    for (const auto& p : c.ports)
      for (const auto& sub : p.subscriptions) peers[c.path.name + "." + p.name].push_back(sub.peer);
  }
  json connections = json::array(), activations = json::array(), not_running = json::array();
  for (const auto& c : file.connections) {
    json j{{"from", c.from}, {"to", c.to}, {"type", c.policy.once ? "once" : "repeated"}, {"policy", to_string(c.policy)}};
    try {
      const auto [o, i] = browser.pair(addressed_port(c.from), addressed_port(c.to));
      const std::string from = PortAddress::parse(o.address).component + "." + o.name;
      const std::string to = PortAddress::parse(i.address).component + "." + i.name;
      j["from"] = from;
      j["to"] = to;
      const auto& made = peers[from];
      j["status"] = std::find(made.begin(), made.end(), to) != made.end() ? "connected" : "to connect";
    } catch (const BrowseError& e) {
      j["status"] = "error";
      j["error"] = e.what();
    } catch (const std::invalid_argument& e) {
      j["status"] = "error";
      j["error"] = e.what();
    } catch (const CORBA::Exception& e) {
      j["status"] = "error";
      j["error"] = c.from + " -> " + c.to + ": " + failure_text(e);
    }
    connections.push_back(std::move(j));
  }
  for (const auto& name : file.activate) {
    const auto it = state.find(name);
    activations.push_back({{"name", name}, {"now", it == state.end() ? "not running" : it->second}});
  }
  for (const auto& c : file.components)
    if (!state.contains(c.name)) not_running.push_back(c.name);
  return json{{"name", file.name},
              {"connections", connections},
              {"activate", activations},
              {"not_running", not_running}};
}

// The running system as a system file `rtm up` accepts (launcher/running_system.h), as the
// page gets it: {"yaml": the file, "left_out": [{"name": .., "why": ..}, ...]}.
json save_system_file(const Browser& browser, const std::string& name) {
  std::vector<LeftOut> left_out;
  const SystemFile file = running_system(browser, name, left_out);
  json left = json::array();
  for (const auto& l : left_out) left.push_back({{"name", l.name}, {"why", l.why}});
  return json{{"yaml", file.to_yaml()}, {"left_out", left}};
}

// A system file's connections and activations applied to the components running now.
json apply_system_file(const Browser& browser, const std::string& yaml) {
  const SystemFile file = SystemFile::parse(yaml, "posted-system-file.yaml");
  json done = json::array(), failed = json::array();
  for (const auto& c : file.connections) {
    try {
      browser.connect(addressed_port(c.from), addressed_port(c.to), c.policy);
      done.push_back("connected " + c.from + " -> " + c.to);
    } catch (const BrowseError& e) {
      failed.push_back(e.what());
    } catch (const std::invalid_argument& e) {
      failed.push_back(c.from + " -> " + c.to + ": " + e.what());
    } catch (const CORBA::Exception& e) {
      failed.push_back(c.from + " -> " + c.to + ": " + failure_text(e));
    }
  }
  for (const auto& name : file.activate) {
    try {
      browser.switch_component(name, Switch::on);
      done.push_back("on " + name);
    } catch (const BrowseError& e) {
      failed.push_back(e.what());
    }
  }
  return json{{"done", done}, {"failed", failed}};
}

// Where a request runs: the streams each on a thread of their own, the switches on workers of
// their own (an `off` never waits behind the rest), the rest on the general workers.
GatedServer::Lane lane_of(const httplib::Request& req) {
  if (req.method == "GET" && (req.path == "/api/events" || req.path == "/api/values/stream"))
    return GatedServer::Lane::stream;
  // POST /api/components/<name>/<on|off|reset> (no std::regex: GCC 12 warns in <regex> under
  // ASan, and -Werror makes that an error).
  const std::string_view path = req.path;
  const std::string_view prefix = "/api/components/";
  const auto verb = path.rfind('/');
  if (req.method == "POST" && path.starts_with(prefix) && verb > prefix.size()) {
    const std::string_view what = path.substr(verb + 1);
    if (what == "on" || what == "off" || what == "reset") return GatedServer::Lane::control;
  }
  return GatedServer::Lane::general;
}

httplib::Headers security_headers() {
  return {{"Content-Security-Policy", kContentSecurityPolicy},
          {"X-Content-Type-Options", "nosniff"},
          {"Referrer-Policy", "no-referrer"}};
}

// On loopback the server answers its own user and root only.
GatedServer::Limits gate_limits(const ServeOptions& options) {
  GatedServer::Limits limits;
  // Room for streams ending while their pages' new ones start; beyond, the gate refuses a
  // stream itself, without starting a thread for it (a client re-opening refused streams in a
  // loop costs a refusal each, not a thread each).
  limits.stream_threads = kStreamsInAll + 8;
  limits.refuse_other_users = is_loopback(options.host);
  return limits;
}

// One plots' stream: every kPlotPeriod (on a fixed schedule; a tick missed is not made up)
// every datum each port wrote since the last event (plot_entry's text per port, or
// {"error": why}), until ended() (the server stops, or the page replaced the stream). Its writes
// also notice a closed page within a period.
bool plot_stream(httplib::DataSink& sink, PlotStream& plot, const std::function<bool()>& ended) {
  using clock = std::chrono::steady_clock;
  for (auto now = clock::now(); now < plot.next && !ended(); now = clock::now())
    std::this_thread::sleep_for(std::min<clock::duration>(plot.next - now, std::chrono::milliseconds(100)));
  if (ended() || plot.ports.empty()) {
    sink.done();
    return true;
  }
  plot.next = std::max(plot.next + kPlotPeriod, clock::now());
  std::string event = "event: values\ndata: {";
  for (std::size_t i = 0; i < plot.ports.size(); ++i) {
    if (i) event += ',';
    event += json(plot.ports[i]).dump() + ':';
    if (plot.subscriptions[i]) {
      event += plot.subscriptions[i]->take();
    } else {
      event += json{{"error", plot.errors[i]}}.dump();
    }
  }
  event += "}\n\n";
  return sink.write(event.data(), event.size());
}

}  // namespace

ServeOptions parse_listen(const std::string& text) {
  const auto colon = text.rfind(':');
  if (colon == std::string::npos) throw std::invalid_argument("--listen '" + text + "': expected HOST:PORT");
  ServeOptions options;
  std::string host = text.substr(0, colon);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  if (!host.empty()) options.host = host;
  const std::string port = text.substr(colon + 1);
  try {
    std::size_t used = 0;
    options.port = std::stoi(port, &used);
    if (used != port.size() || options.port < 0 || options.port > 65535) throw std::out_of_range("port");
  } catch (const std::exception&) {
    throw std::invalid_argument("--listen '" + text + "': the port must be 0 to 65535");
  }
  return options;
}

struct WebServer::Impl {
  Impl(const Browser& b, ServeOptions o, std::string t) : browser(b), options(std::move(o)), token(std::move(t)) {}

  const Browser& browser;
  ServeOptions options;
  std::string token;
  int port = 0;
  std::atomic<bool> stopping{false};
  SystemFeed feed{[this] { return system_event(); }, kSystemPeriod};
  StreamSlots streams{kStreamsInAll};
  // Each page's plot subscriptions, held by its streams; before the server, so that they
  // outlive its threads.
  mutable PagePlots page_plots;
  // After the feed: gone (with the streams' subscriptions) before it. The screen is the one
  // below, asked where a request has arrived and again where httplib routes it.
  GatedServer server{[this](const httplib::Request& req, httplib::Response& res) { return screen(req, res); },
                     lane_of, security_headers(), gate_limits(options)};
  mutable std::mutex ports_mu;
  mutable std::map<std::string, std::pair<std::string, RTM::OutPort_var>> ports;

  // The Host header values this server answers to (all, when it listens on every address).
  bool host_allowed(const std::string& host) const {
    if (options.host == "0.0.0.0" || options.host == "::") return true;
    const std::string p = fmt::format(":{}", port);
    if (is_loopback(options.host))
      return host == fmt::format("127.0.0.1{}", p) || host == fmt::format("localhost{}", p) ||
             host == fmt::format("[::1]{}", p);
    return host == fmt::format("{}{}", options.host, p) || host == fmt::format("[{}]{}", options.host, p);
  }

  httplib::Server::HandlerResponse screen(const httplib::Request& req, httplib::Response& res) const {
    const std::string host = req.get_header_value("Host");
    if (!host_allowed(host)) {
      refuse(res, 403, "refused: request for host '" + host + "', not this server's address");
      return httplib::Server::HandlerResponse::Handled;
    }
    if (req.has_header("Origin") && req.get_header_value("Origin") != "http://" + host) {
      refuse(res, 403, "refused: a cross-origin request (from " + req.get_header_value("Origin") + ")");
      return httplib::Server::HandlerResponse::Handled;
    }
    if (req.path.rfind("/api/", 0) == 0) {
      const std::string given =
          req.has_header("X-RTM-Token") ? req.get_header_value("X-RTM-Token") : req.get_param_value("token");
      if (!same_secret(given, token)) {
        refuse(res, 401, "refused: this API needs the token rtm serve printed with its URL");
        return httplib::Server::HandlerResponse::Handled;
      }
    }
    return httplib::Server::HandlerResponse::Unhandled;
  }

  // What the page draws: states, timing, contracts, ports and subscriptions (not statistics and
  // parameters: those come with /api/components/<name>, when the page asks). The streams'
  // look, twice a second, asks the components in turn (Browser::Asking).
  json system(Browser::Asking asking = Browser::Asking::parallel) const {
    json list = json::array();
    const std::vector<ComponentInfo> listed = browser.list("", Browser::Detail::wiring, asking);
    // The page draws a composite (it says its "members") as a frame around them, one level
    // deep: a member is the first composite's that names it, and a composite is no member.
    std::map<std::string, std::string> member_of;
    for (const auto& c : listed)
      for (const auto& m : c.members) member_of.emplace(m, c.path.name);
    for (const auto& c : listed) {
      json j = component_json(c, false);
      const auto it = member_of.find(c.path.name);
      if (it != member_of.end() && c.members.empty() && it->second != c.path.name) j["member_of"] = it->second;
      // false: the page shows the name as text with a mark, and offers nothing to do to it.
      j["name_ok"] = follows_naming_rule(c.path.name) && follows_naming_rule(c.path.host);
      if (c.timing) j["timing"] = timing_json(*c.timing);
      list.push_back(std::move(j));
    }
    return list;
  }

  // The latest datum of several OutPorts at once (the page's plots, up to 33 times a second):
  // {"<address>": datum as /api/ports gives it, or {"error": why}}.
  json values(const std::string& ports) const {
    json out = json::object();
    for (const std::string& address : split_ports(ports)) out[address] = value_or_error(address);
    return out;
  }

  // One port's datum as /api/ports gives it, or {"error": why}: a port that fails is shown
  // failing beside the others.
  json value_or_error(const std::string& address) const {
    try {
      return port_value(address);
    } catch (const BrowseError& e) {
      return json{{"error", e.what()}};
    } catch (const std::invalid_argument& e) {
      return json{{"error", e.what()}};
    } catch (const CORBA::Exception& e) {
      return json{{"error", failure_text(e)}};
    }
  }

  // An OutPort by address, resolved once (naming service, component, port list) and then
  // kept: the plots ask for the same ports 25 times a second.
  std::pair<std::string, RTM::OutPort_var> out_port(const std::string& address) const {
    {
      std::lock_guard lock(ports_mu);
      if (auto it = ports.find(address); it != ports.end()) return {it->second.first, it->second.second};
    }
    const ResolvedPort p = browser.port(addressed_port(address));
    if (p.direction != Direction::out) throw BrowseError(p.address + " is an InPort; only OutPorts have a value to get");
    RTM::OutPort_var out = RTM::OutPort::_narrow(p.object);
    std::lock_guard lock(ports_mu);
    ports[address] = {p.address, out};
    return {p.address, out};
  }

  // A plotted port's subscription (the page's earlier stream's, PagePlots), or why there is none.
  void subscribe_plot(PlotStream& plot, const std::string& page, const std::string& address) const {
    std::string why;
    try {
      plot.subscriptions.push_back(page_plots.take(page, address, [&] {
        rtm::Orb* orb = rtm::Orb::instance();
        if (orb == nullptr) throw BrowseError("this server has no ORB to take a port's data with");
        addressed_port(address);
        return std::make_shared<PlotSubscription>(browser, *orb, address);
      }));
      plot.errors.emplace_back();
      return;
    } catch (const BrowseError& e) {
      why = e.what();
    } catch (const std::invalid_argument& e) {
      why = e.what();
    } catch (const CORBA::Exception& e) {
      why = address + ": " + failure_text(e);
    }
    plot.subscriptions.push_back(nullptr);
    plot.errors.push_back(why);
  }

  json port_value(const std::string& address) const {
    auto [name, out] = out_port(address);
    CORBA::Any_var value;
    try {
      value = out->get();
    } catch (const CORBA::BAD_INV_ORDER& e) {
      if (e.minor() == rtm::kMinorNoDataYet) throw BrowseError(name + " has no data yet");
      throw;
    } catch (const CORBA::SystemException&) {
      std::lock_guard lock(ports_mu);
      ports.erase(address);  // resolved afresh next time: the process may have restarted
      throw;
    }
    json j = format_json(value.in());
    j["port"] = name;
    return j;
  }

  json wire(const httplib::Request& req, bool connecting) const {
    const json body = json::parse(req.body);
    const PortAddress from = addressed_port(body.at("from").get<std::string>());
    const PortAddress to = addressed_port(body.at("to").get<std::string>());
    // "policy": a whole connection policy (rtm/conn_policy.h's text); "type", when given, sets
    // once or repeated.
    std::optional<bool> once;
    if (body.contains("type")) {
      const std::string type = body.at("type").get<std::string>();
      if (type != "once" && type != "repeated") throw std::invalid_argument("type must be once or repeated");
      once = type == "once";
    }
    const ConnPolicy policy = parse_conn_policy(body.value("policy", ""), once);
    const char* kind = policy.once ? "once" : "repeated";
    if (connecting) {
      browser.connect(from, to, policy);
    } else {
      browser.disconnect(from, to, policy.once ? RTM::once : RTM::repeated);
    }
    return json{{connecting ? "connected" : "disconnected",
                 {{"from", from.to_string()}, {"to", to.to_string()}, {"type", kind}, {"policy", to_string(policy)}}}};
  }

  json preview(const std::string& yaml) const { return preview_system_file(browser, yaml); }

  json switch_to(const std::string& name, const std::string& verb) const {
    const Switch what = verb == "on" ? Switch::on : verb == "off" ? Switch::off : Switch::reset;
    browser.switch_component(addressed(name), what);
    return json{{verb, name}};
  }

  // One SSE stream: the system when it changed (polled by the feed, at most every
  // kSystemPeriod for all pages together), else a comment every kKeepAlive; it ends when the
  // server stops or the page opened another (looked at every kReplacedLook).
  bool stream(httplib::DataSink& sink, SystemFeed::Subscription& subscription, const StreamSlots::Slot& slot,
              std::chrono::steady_clock::time_point& written) const {
    for (;;) {
      if (slot.replaced() || stopping.load() || feed.stopped()) {
        sink.done();
        return true;
      }
      const auto now = std::chrono::steady_clock::now();
      if (const auto update = subscription.next(kReplacedLook)) {
        written = now;
        const std::string event = "event: system\ndata: " + update->text + "\n\n";
        return sink.write(event.data(), event.size());
      }
      if (now - written >= kKeepAlive) {
        written = now;
        return sink.write(": alive\n\n", 10);
      }
    }
  }

  std::string system_event() const {
    try {
      return system(Browser::Asking::in_turn).dump();
    } catch (const std::exception& e) {
      return json{{"error", e.what()}}.dump();
    } catch (const CORBA::Exception& e) {
      return json{{"error", failure_text(e)}}.dump();
    }
  }

  void routes() {
    const auto file = [](const char* text, const char* type) {
      return [text, type](const httplib::Request&, httplib::Response& res) { res.set_content(text, type); };
    };
    server.Get("/", file(kWebPage, "text/html; charset=utf-8"));
    server.Get("/app.js", file(kWebScript, "text/javascript; charset=utf-8"));
    server.Get("/style.css", file(kWebStyle, "text/css; charset=utf-8"));
    component_routes();
    port_routes();
    server.Get("/api/system", [this](const httplib::Request&, httplib::Response& res) { answer(res, [&] { return system(); }); });
    server.Get("/api/system-file", [this](const httplib::Request& req, httplib::Response& res) {
      answer(res, [&] { return save_system_file(browser, req.get_param_value("name")); });
    });
    server.Post("/api/system-file", [this](const httplib::Request& req, httplib::Response& res) {
      answer(res, [&] { return apply_system_file(browser, req.body); });
    });
    server.Post("/api/system-file/preview", [this](const httplib::Request& req, httplib::Response& res) {
      answer(res, [&] { return preview(req.body); });
    });
    server.Get("/api/events", [this](const httplib::Request& req, httplib::Response& res) {
      decide(res, [&] {
        auto slot = streams.open(req.get_param_value("page"), StreamSlots::Kind::system);
        // Held by the response: the page counts as connected until its stream ends.
        auto subscription = std::make_shared<SystemFeed::Subscription>(feed);
        res.set_header("Cache-Control", "no-store");
        res.set_chunked_content_provider("text/event-stream", [this, slot, subscription, written = std::chrono::steady_clock::now()](
                                                                  std::size_t, httplib::DataSink& sink) mutable {
          return stream(sink, *subscription, *slot, written);
        });
      });
    });
  }

  // A component's description, its switches and its parameters. Each name in a path is taken
  // as decoded (a '/' in it, sent as %2F, stays in it, and is refused with the naming rule's
  // sentence); the parameters' route first, so that a parameter named "on" is one.
  void component_routes() {
    server.Get(R"(/api/components/(.+))", [this](const httplib::Request& req, httplib::Response& res) {
      answer(res, [&] { return component_json(browser.describe(addressed(req.matches[1].str())), true); });
    });
    server.Post(R"(/api/components/(.+?)/parameters/(.+))", [this](const httplib::Request& req, httplib::Response& res) {
      answer(res, [&] {
        const json body = json::parse(req.body);
        const std::string value = browser.set_parameter(addressed(req.matches[1].str()), req.matches[2].str(),
                                                        body.at("value").get<std::string>());
        return json{{"component", req.matches[1].str()}, {"parameter", req.matches[2].str()}, {"value", value}};
      });
    });
    server.Post(R"(/api/components/(.+)/(on|off|reset))", [this](const httplib::Request& req, httplib::Response& res) {
      answer(res, [&] { return switch_to(req.matches[1].str(), req.matches[2].str()); });
    });
  }

  void port_routes() {
    server.Post("/api/connect", [this](const httplib::Request& req, httplib::Response& res) {
      answer(res, [&] { return wire(req, true); });
    });
    server.Post("/api/disconnect", [this](const httplib::Request& req, httplib::Response& res) {
      answer(res, [&] { return wire(req, false); });
    });
    server.Get("/api/values", [this](const httplib::Request& req, httplib::Response& res) {
      answer(res, [&] { return values(req.get_param_value("ports")); });
    });
    server.Get(R"(/api/ports/(.+))", [this](const httplib::Request& req, httplib::Response& res) {
      answer(res, [&] { return port_value(req.matches[1].str()); });
    });
    server.Get("/api/values/stream", [this](const httplib::Request& req, httplib::Response& res) {
      decide(res, [&] {
        auto slot = streams.open(req.get_param_value("page"), StreamSlots::Kind::values);
        auto plot = std::make_shared<PlotStream>();
        for (const std::string& address : split_ports(req.get_param_value("ports")))
          if (std::find(plot->ports.begin(), plot->ports.end(), address) == plot->ports.end())
            plot->ports.push_back(address);
        if (plot->ports.size() > kPlotPortsMax)
          throw std::invalid_argument(fmt::format("ports: at most {} in one plots' stream", kPlotPortsMax));
        const std::string page = req.get_param_value("page");
        for (const std::string& address : plot->ports) subscribe_plot(*plot, page, address);
        res.set_header("Cache-Control", "no-store");
        res.set_chunked_content_provider("text/event-stream", [this, plot, slot](std::size_t, httplib::DataSink& sink) {
          return plot_stream(sink, *plot, [&] { return stopping.load() || slot->replaced(); });
        });
      });
    });
  }
};

WebServer::WebServer(const Browser& browser, ServeOptions options)
    : token_(random_token()) {
  impl_ = std::make_unique<Impl>(browser, std::move(options), token_);
  impl_->routes();
  add_recording_routes(impl_->server);
}

WebServer::~WebServer() = default;

void WebServer::run(const std::function<bool()>& interrupted, const std::function<void(const std::string&)>& print_url) {
  Impl& s = *impl_;
  s.port = s.options.port == 0 ? s.server.bind_to_any_port(s.options.host)
                               : (s.server.bind_to_port(s.options.host, s.options.port) ? s.options.port : -1);
  if (s.port < 0)
    throw std::runtime_error(fmt::format("cannot listen on {}:{}", s.options.host, s.options.port));
  const bool v6 = s.options.host.find(':') != std::string::npos;
  const std::string shown = v6 ? "[" + s.options.host + "]" : s.options.host;
  print_url(fmt::format("http://{}:{}/#token={}", shown, s.port, token_));
  std::thread serving([&s] { s.server.serve(); });
  while (!interrupted()) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  s.stopping.store(true);  // the plots' streams end
  s.feed.stop();           // wakes the system's streams, which end
  s.server.stop_serving();
  serving.join();          // every request in hand answered, every stream ended
}

}  // namespace rtm::cli
