// rtm: the command-line component browser and system launcher.
//
//   rtm ls [path] [-l] [--clean]          the naming tree: components, state, period, ports
//   rtm cat <comp>                        one component: ports, types, subscriptions, counters
//   rtm connect|disconnect <out> <in>     subscribe/unsubscribe (RTM.idl), --once
//   rtm on|off|reset <comp>...            reset: leave COMPONENT_ERROR (RTMExt)
//   rtm get <comp>.<out>                  pull one datum
//   rtm put <comp>.<in> <values>...       inject one datum
//   rtm watch <comp>.<out>                stream a port live (--rate, --csv, --count, --duration)
//   rtm up <system.yaml> / rtm down <system.yaml|name>
//
// Every command takes --naming host:port (or $RTM_NAMING) and --json; exit code 0 ok,
// 1 failed, 2 usage.
#include "browser.h"
#include "launcher.h"
#include "system_file.h"
#include "values.h"
#include "watch_port.h"

#include "rtm/data.h"
#include "rtm/log.h"
#include "rtm/orb.h"

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>

namespace {

using namespace rtm::cli;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

constexpr int kOk = 0, kFailed = 1, kUsage = 2;

std::atomic<bool> g_interrupted{false};
extern "C" void on_interrupt(int) { g_interrupted.store(true); }

struct Options {
  std::string naming;
  bool json = false;
  int timeout_ms = 5000;  // on() of a composite makes several remote calls of its own
};

// Turns any failure into a one-line message and the exit code.
class Failure : public std::runtime_error {
 public:
  Failure(const std::string& what, int code) : std::runtime_error(what), code(code) {}
  int code;
};

std::string corba_name(const CORBA::Exception& e) {
  const char* n = e._name();
  return n ? n : "CORBA exception";
}

std::string us(unsigned long long ns) { return fmt::format("{:.1f}", ns / 1000.0); }

json port_json(const PortInfo& p) {
  json j{{"name", p.name}, {"direction", to_string(p.direction)}, {"index", p.index},
         {"type", p.type}};
  if (p.extended) {
    j["counters"] = {{"accepted", p.counters.accepted}, {"rejected", p.counters.rejected},
                     {"dropped", p.counters.dropped},   {"pushed", p.counters.pushed},
                     {"failed", p.counters.failed}};
    if (!p.last_error.empty()) j["last_error"] = p.last_error;
  }
  if (p.direction == Direction::out) {
    j["subscriptions"] = json::array();
    for (const auto& s : p.subscriptions) {
      j["subscriptions"].push_back({{"peer", s.peer}, {"type", s.req_type},
                                    {"in_process", s.in_process}, {"pushed", s.pushed},
                                    {"dropped", s.dropped}, {"failures", s.failures}});
    }
  }
  return j;
}

json component_json(const ComponentInfo& c, bool detailed) {
  json j{{"host", c.path.host}, {"name", c.path.name},
         {"alive", c.liveness == Liveness::alive}};
  if (c.liveness == Liveness::dead) {
    j["dead_reason"] = c.dead_reason;
    return j;
  }
  j["kind"] = c.kind;
  j["state"] = c.state;
  if (!c.last_error.empty()) j["last_error"] = c.last_error;
  if (c.timing) {
    j["period_ns"] = c.timing->period_ns;
    if (detailed) {
      j["timing"] = {{"cycles", c.timing->cycles},
                     {"overruns", c.timing->overruns},
                     {"lateness_p50_ns", c.timing->lateness_p50_ns},
                     {"lateness_p99_ns", c.timing->lateness_p99_ns},
                     {"lateness_max_ns", c.timing->lateness_max_ns},
                     {"mean_period_error_ns", c.timing->mean_period_error_ns}};
    }
  }
  j["ports"] = json::array();
  for (const auto& p : c.ports) j["ports"].push_back(port_json(p));
  return j;
}

std::string short_type(const std::string& type) {
  return type.rfind("RTM::", 0) == 0 ? type.substr(5) : type;
}

std::string period_text(const ComponentInfo& c) {
  if (!c.timing || c.timing->period_ns == 0) return "-";
  return fmt::format("{:g} ms", c.timing->period_ns / 1e6);
}

void print_ls(const std::vector<ComponentInfo>& comps, bool detailed) {
  std::string host;
  for (const auto& c : comps) {
    if (c.path.host != host) {
      host = c.path.host;
      fmt::print("{}\n", host);
    }
    if (c.liveness == Liveness::dead) {
      fmt::print("  {:<16} dead ({}): process gone; `rtm ls --clean` removes it\n", c.path.name,
                 c.dead_reason);
      continue;
    }
    std::string ins, outs;
    for (const auto& p : c.ports) {
      auto& s = p.direction == Direction::in ? ins : outs;
      s += fmt::format("{}{}:{}", s.empty() ? "" : " ", p.name, short_type(p.type));
    }
    fmt::print("  {:<16} {:<5} {:<11} {:<8} in[{}] out[{}]\n", c.path.name, c.state,
               c.kind.empty() ? "-" : c.kind, period_text(c), ins, outs);
    if (detailed && c.timing) {
      const auto& t = *c.timing;
      fmt::print("  {:<16} lateness p50 {} us  p99 {} us  max {} us  overruns {} of {} cycles\n",
                 "", us(t.lateness_p50_ns), us(t.lateness_p99_ns), us(t.lateness_max_ns),
                 t.overruns, t.cycles);
    }
  }
  if (comps.empty()) fmt::print("(no components)\n");
}

void print_cat(const ComponentInfo& c) {
  fmt::print("{}  kind {}  state {}  period {}\n", c.path.to_string(),
             c.kind.empty() ? "-" : c.kind, c.state, period_text(c));
  if (!c.last_error.empty()) fmt::print("  error: {}\n", c.last_error);
  if (c.timing) {
    const auto& t = *c.timing;
    fmt::print("  lateness p50 {} us  p99 {} us  max {} us  overruns {} of {} cycles\n",
               us(t.lateness_p50_ns), us(t.lateness_p99_ns), us(t.lateness_max_ns), t.overruns,
               t.cycles);
  }
  for (const auto& p : c.ports) {
    std::string counters;
    if (p.extended && p.direction == Direction::in) {
      counters = fmt::format("accepted {}  rejected {}  dropped {}", p.counters.accepted,
                             p.counters.rejected, p.counters.dropped);
    } else if (p.extended) {
      counters = fmt::format("written {}  pushed {}  dropped {}  failed {}", p.counters.accepted,
                             p.counters.pushed, p.counters.dropped, p.counters.failed);
    }
    fmt::print("  {:<6} {:<14} {:<20} {}\n", fmt::format("{}{}", to_string(p.direction), p.index),
               p.name, p.type, counters);
    if (!p.last_error.empty()) fmt::print("        last error: {}\n", p.last_error);
    for (const auto& s : p.subscriptions) {
      fmt::print("        -> {} ({}{})  pushed {}  dropped {}{}\n", s.peer, s.req_type,
                 s.in_process ? ", in-process" : "", s.pushed, s.dropped,
                 s.failures ? fmt::format("  failing x{}", s.failures) : "");
    }
  }
}

// ------------------------------------------------------------------ watch

int watch(const Browser& browser, rtm::Orb& orb, const std::string& address, double rate_hz,
          const std::string& csv_path, long count, double duration_s, bool as_json) {
  ResolvedPort port = browser.port(PortAddress::parse(address));
  if (port.direction != Direction::out) {
    throw Failure(fmt::format("{} is an InPort; watch an OutPort", port.address), kFailed);
  }
  RTM::OutPort_var out = RTM::OutPort::_narrow(port.object);
  const std::string owner = fmt::format("rtm-watch-{}", ::getpid());
  auto* servant = new WatchPort(owner, port.type, 4096);
  PortableServer::ServantBase_var keep(servant);
  CORBA::Object_var ref = orb.activate(servant);
  RTM::InPort_var in = RTM::InPort::_narrow(ref);
  if (!out->subscribe(RTM::repeated, in)) {
    orb.deactivate(servant);
    throw Failure(fmt::format("{} refused the watch subscription", port.address), kFailed);
  }
  RTM::OutPortEx_var out_ex = RTM::OutPortEx::_narrow(out);
  auto publisher_dropped = [&]() -> unsigned long long {
    if (CORBA::is_nil(out_ex)) return 0;
    try {
      RTM::SubscriptionInfoList_var subs = out_ex->subscriptions();
      for (CORBA::ULong i = 0; i < subs->length(); ++i) {
        if (subs[i].subscriber->_is_equivalent(in)) return subs[i].dropped;
      }
    } catch (const CORBA::Exception&) {
    }
    return 0;
  };

  std::ofstream csv;
  if (!csv_path.empty()) {
    csv.open(csv_path);
    if (!csv) throw Failure(fmt::format("cannot write {}", csv_path), kFailed);
    csv << "time_ns";
  }
  bool csv_header_done = csv_path.empty();
  const bool live_table = !as_json && ::isatty(STDOUT_FILENO) && count <= 0;
  const auto units = units_for_port(port.name, 6, port.component_kind, false);
  const auto start = Clock::now();
  const auto refresh = std::chrono::duration<double>(1.0 / std::max(rate_hz, 0.1));
  auto next_refresh = start;
  std::vector<CORBA::Any> batch;
  std::uint64_t shown = 0, window_count = 0;
  auto window_start = start;
  double rate = 0;
  std::string latest;
  int exit_code = kOk;
  while (!g_interrupted.load()) {
    batch.clear();
    servant->drain(batch, std::chrono::milliseconds(50));
    for (const auto& any : batch) {
      ++shown;
      ++window_count;
      Sample s = to_sample(any);
      if (csv.is_open()) {
        if (!csv_header_done) {
          for (std::size_t i = 0; i < s.values.size(); ++i) csv << ",v" << i;
          csv << "\n";
          csv_header_done = true;
        }
        csv << s.time_ns;
        for (double v : s.values) csv << "," << v;
        csv << "\n";
      }
      if (as_json) {
        fmt::print("{}\n", format_json(any).dump());
      } else if (!live_table) {
        fmt::print("{}\n", format_text(any, units));
      } else {
        latest = format_text(any, units);
      }
      if (count > 0 && static_cast<long>(shown) >= count) break;
    }
    const auto now = Clock::now();
    if (now - window_start >= std::chrono::seconds(1)) {
      rate = window_count / std::chrono::duration<double>(now - window_start).count();
      window_start = now;
      window_count = 0;
    }
    if (live_table && now >= next_refresh) {
      next_refresh = now + std::chrono::duration_cast<Clock::duration>(refresh);
      fmt::print("\r\x1b[2K{}  {}\n\x1b[2K  received {}  rate {:.1f} Hz  dropped {} (publisher) "
                 "+ {} (display)\x1b[1A",
                 port.address, latest.empty() ? "(waiting for data)" : latest, shown, rate,
                 publisher_dropped(), servant->overflowed());
      std::fflush(stdout);
    }
    if (count > 0 && static_cast<long>(shown) >= count) break;
    if (duration_s > 0 && now - start >= std::chrono::duration<double>(duration_s)) break;
  }
  const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  const unsigned long long dropped_pub = publisher_dropped();
  try {
    out->unsubscribe(RTM::repeated, in);
  } catch (const CORBA::Exception& e) {
    fmt::print(stderr, "rtm watch: unsubscribe from {} failed: {}\n", port.address, corba_name(e));
    exit_code = kFailed;
  }
  orb.deactivate(servant);
  if (live_table) fmt::print("\n\n");
  const std::string summary =
      fmt::format("{}: received {} in {:.2f} s ({:.1f} Hz), dropped {} by the publisher, {} by "
                  "the display, {} of a wrong type",
                  port.address, shown, elapsed, elapsed > 0 ? shown / elapsed : 0.0, dropped_pub,
                  servant->overflowed(), servant->rejected());
  if (as_json) {
    fmt::print("{}\n", json{{"summary", {{"port", port.address}, {"received", shown},
                                         {"seconds", elapsed}, {"dropped_publisher", dropped_pub},
                                         {"dropped_display", servant->overflowed()},
                                         {"rejected", servant->rejected()}}}}
                           .dump());
  } else {
    fmt::print(stderr, "{}\n", summary);
  }
  return exit_code;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"rtm: browse, wire and launch RT components"};
  app.require_subcommand(1);
  Options opt;
  app.add_option("--naming", opt.naming, "naming service host:port (default $RTM_NAMING or 127.0.0.1:2809)");
  app.add_flag("--json", opt.json, "machine-readable output");
  app.add_option("--timeout", opt.timeout_ms, "bound on each remote call, ms")->check(CLI::PositiveNumber);

  auto* ls = app.add_subcommand("ls", "list components in the naming service");
  std::string ls_path;
  bool ls_long = false, ls_clean = false, ls_names = false;
  ls->add_option("path", ls_path, "host or host/name to list");
  ls->add_flag("-l,--long", ls_long, "add lateness and overrun statistics");
  ls->add_flag("--clean", ls_clean, "remove bindings whose process is gone");
  ls->add_flag("--names", ls_names, "only the names, one per line (for scripts and completion)");

  auto* cat = app.add_subcommand("cat", "show one component's ports, subscriptions and counters");
  std::string cat_comp;
  cat->add_option("component", cat_comp, "name or host/name")->required();

  std::string conn_out, conn_in;
  bool conn_once = false;
  auto* connect = app.add_subcommand("connect", "subscribe an InPort to an OutPort");
  auto* disconnect = app.add_subcommand("disconnect", "unsubscribe an InPort from an OutPort");
  for (auto* sub : {connect, disconnect}) {
    sub->add_option("out", conn_out, "<component>.<OutPort>")->required();
    sub->add_option("in", conn_in, "<component>.<InPort>")->required();
    sub->add_flag("--once", conn_once, "a once subscription (next datum only) instead of repeated");
  }

  std::vector<std::string> onoff_comps;
  auto* on = app.add_subcommand("on", "start components' activities");
  auto* off = app.add_subcommand("off", "stop components' activities");
  auto* reset = app.add_subcommand("reset", "take components out of the error state (then `on`)");
  for (auto* sub : {on, off, reset}) sub->add_option("components", onoff_comps)->required();

  auto* get = app.add_subcommand("get", "pull the latest datum of an OutPort");
  std::string get_port;
  get->add_option("port", get_port, "<component>.<OutPort>")->required();

  auto* put = app.add_subcommand("put", "send one datum to an InPort");
  std::string put_port;
  std::vector<std::string> put_values;
  put->add_option("port", put_port, "<component>.<InPort>")->required();
  put->add_option("values", put_values, "the values (6 for TimedFloat6)")->required()->allow_extra_args();

  auto* watchc = app.add_subcommand("watch", "stream an OutPort's data live");
  std::string watch_port;
  double watch_rate = 10, watch_duration = 0;
  long watch_count = 0;
  std::string watch_csv;
  watchc->add_option("port", watch_port, "<component>.<OutPort>")->required();
  watchc->add_option("--rate", watch_rate, "display refresh rate, Hz")->check(CLI::PositiveNumber);
  watchc->add_option("--csv", watch_csv, "also write every datum to this CSV file");
  watchc->add_option("--count", watch_count, "stop after this many data");
  watchc->add_option("--duration", watch_duration, "stop after this many seconds");

  auto* up = app.add_subcommand("up", "launch a system file's components, connect and turn them on");
  std::string up_file;
  int up_timeout_ms = 10000;
  up->add_option("file", up_file, "system file (YAML)")->required();
  up->add_option("--bind-timeout", up_timeout_ms, "ms to wait for each component to bind");

  auto* down = app.add_subcommand("down", "stop a system started by `rtm up`");
  std::string down_what;
  down->add_option("system", down_what, "the system file, or the system's name")->required();

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? kOk : kUsage;
  }

  rtm::log().set_level(spdlog::level::warn);
  try {
    std::optional<SystemFile> system;
    if (up->parsed()) system = SystemFile::load(up_file);
    rtm::NamingAddress naming;
    try {
      if (!opt.naming.empty()) {
        naming = rtm::NamingAddress::parse(opt.naming);
      } else if (system && system->naming && !std::getenv("RTM_NAMING")) {
        naming = rtm::NamingAddress::parse(*system->naming);
      } else {
        naming = rtm::NamingAddress::from_environment();
      }
    } catch (const std::invalid_argument& e) {
      throw Failure(e.what(), kUsage);
    }
    std::vector<std::string> orb_args;
    if (naming.host == "127.0.0.1" || naming.host == "localhost" || naming.host == "::1") {
      orb_args = {"-ORBendPoint", "giop:tcp:127.0.0.1:"};
    }
    orb_args.insert(orb_args.end(), {"-ORBclientCallTimeOutPeriod", std::to_string(opt.timeout_ms),
                                     "-ORBclientConnectTimeOutPeriod", std::to_string(opt.timeout_ms)});
    rtm::Orb orb(orb_args);
    Browser browser(orb.orb(), naming, std::chrono::milliseconds(opt.timeout_ms));
    std::signal(SIGINT, on_interrupt);
    std::signal(SIGTERM, on_interrupt);

    if (ls->parsed()) {
      if (ls_clean) {
        auto removed = browser.clean(ls_path);
        if (opt.json) {
          json j = json::array();
          for (const auto& p : removed) j.push_back(p.to_string());
          fmt::print("{}\n", json{{"removed", j}}.dump());
        } else {
          for (const auto& p : removed) fmt::print("removed dead binding {}\n", p.to_string());
          if (removed.empty()) fmt::print("no dead bindings\n");
        }
        return kOk;
      }
      auto comps = browser.list(ls_path, ls_long);
      if (ls_names) {
        for (const auto& c : comps) fmt::print("{}\n", c.path.name);
      } else if (opt.json) {
        json j = json::array();
        for (const auto& c : comps) j.push_back(component_json(c, ls_long));
        fmt::print("{}\n", j.dump(2));
      } else {
        print_ls(comps, ls_long);
      }
      return kOk;
    }
    if (cat->parsed()) {
      auto info = browser.describe(cat_comp);
      if (opt.json) {
        fmt::print("{}\n", component_json(info, true).dump(2));
      } else {
        print_cat(info);
      }
      return kOk;
    }
    if (connect->parsed() || disconnect->parsed()) {
      PortAddress o = PortAddress::parse(conn_out), i = PortAddress::parse(conn_in);
      const auto type = conn_once ? RTM::once : RTM::repeated;
      if (connect->parsed()) {
        browser.connect(o, i, type);
      } else {
        browser.disconnect(o, i, type);
      }
      const char* verb = connect->parsed() ? "connected" : "disconnected";
      if (opt.json) {
        fmt::print("{}\n", json{{verb, {{"from", o.to_string()}, {"to", i.to_string()},
                                        {"type", conn_once ? "once" : "repeated"}}}}
                               .dump());
      } else {
        fmt::print("{} {} -> {} ({})\n", verb, o.to_string(), i.to_string(),
                   conn_once ? "once" : "repeated");
      }
      return kOk;
    }
    if (on->parsed() || off->parsed() || reset->parsed()) {
      const char* verb = on->parsed() ? "on" : off->parsed() ? "off" : "reset";
      int code = kOk;
      json results = json::object();
      for (const auto& name : onoff_comps) {
        try {
          auto comp = browser.component(name);
          if (on->parsed()) {
            comp->on();
          } else if (off->parsed()) {
            comp->off();
          } else {
            RTM::RtComponentEx_var ex = RTM::RtComponentEx::_narrow(comp);
            if (CORBA::is_nil(ex)) throw BrowseError(name + " is a plain RtComponent: it has no reset");
            ex->reset();
          }
          results[name] = "ok";
          if (!opt.json) fmt::print("{} {}\n", verb, name);
        } catch (const CORBA::Exception& e) {
          code = kFailed;
          std::string why = corba_name(e);
          if (const auto* bio = dynamic_cast<const CORBA::BAD_INV_ORDER*>(&e);
              bio && bio->minor() == rtm::kMinorComponentError) {
            why = "the component is in error; `rtm cat` shows why, `rtm reset` clears it";
          }
          results[name] = why;
          if (!opt.json) fmt::print(stderr, "rtm: {} {}: {}\n", verb, name, why);
        } catch (const BrowseError& e) {
          code = kFailed;
          results[name] = e.what();
          if (!opt.json) fmt::print(stderr, "rtm: {}\n", e.what());
        }
      }
      if (opt.json) fmt::print("{}\n", results.dump());
      return code;
    }
    if (get->parsed()) {
      ResolvedPort p = browser.port(PortAddress::parse(get_port));
      if (p.direction != Direction::out) throw Failure(p.address + " is an InPort; get reads OutPorts", kFailed);
      RTM::OutPort_var out = RTM::OutPort::_narrow(p.object);
      CORBA::Any_var value;
      try {
        value = out->get();
      } catch (const CORBA::BAD_INV_ORDER& e) {
        if (e.minor() == rtm::kMinorNoDataYet) throw Failure(p.address + " has no data yet", kFailed);
        throw;
      }
      if (opt.json) {
        json j = format_json(value.in());
        j["port"] = p.address;
        fmt::print("{}\n", j.dump());
      } else {
        fmt::print("{}\n", format_text(value.in(), units_for_port(p.name, 6, p.component_kind, false)));
      }
      return kOk;
    }
    if (put->parsed()) {
      ResolvedPort p = browser.port(PortAddress::parse(put_port));
      if (p.direction != Direction::in) throw Failure(p.address + " is an OutPort; put writes InPorts", kFailed);
      CORBA::Any value;
      try {
        value = parse_value(p.type, put_values);
      } catch (const ValueError& e) {
        throw Failure(fmt::format("{}: {}", p.address, e.what()), kUsage);
      }
      RTM::InPort_var in = RTM::InPort::_narrow(p.object);
      in->put(value);
      if (opt.json) {
        json j = format_json(value);
        j["port"] = p.address;
        fmt::print("{}\n", j.dump());
      } else {
        fmt::print("put {}  {}\n", p.address, format_text(value));
      }
      return kOk;
    }
    if (watchc->parsed()) {
      return watch(browser, orb, watch_port, watch_rate, watch_csv, watch_count, watch_duration,
                   opt.json);
    }
    LaunchOptions launch;
    launch.bind_timeout = std::chrono::milliseconds(up_timeout_ms);
    if (!opt.json) launch.progress = [](const std::string& line) { fmt::print("{}\n", line); };
    if (up->parsed()) {
      SystemState state = system_up(*system, browser, naming, launch);
      if (opt.json) {
        json procs = json::array();
        for (const auto& p : state.processes) {
          procs.push_back({{"name", p.name}, {"pid", p.pid}, {"log", p.log.string()}});
        }
        fmt::print("{}\n", json{{"system", state.system}, {"processes", procs}}.dump());
      } else {
        fmt::print("system {} is up ({} components); `rtm down {}` stops it\n", state.system,
                   state.processes.size(), state.system);
      }
      return kOk;
    }
    if (down->parsed()) {
      std::string name = down_what;
      if (std::filesystem::exists(down_what) && std::filesystem::is_regular_file(down_what)) {
        name = SystemFile::load(down_what).name;
      }
      SystemState state = SystemState::load(name);
      auto killed = system_down(state, &browser, launch);
      if (opt.json) {
        fmt::print("{}\n", json{{"system", state.system}, {"killed", killed}}.dump());
      } else {
        for (const auto& k : killed) fmt::print("{} did not stop on SIGTERM: killed\n", k);
        fmt::print("system {} is down\n", state.system);
      }
      return kOk;
    }
  } catch (const Failure& e) {
    fmt::print(stderr, "rtm: {}\n", e.what());
    return e.code;
  } catch (const std::invalid_argument& e) {
    fmt::print(stderr, "rtm: {}\n", e.what());
    return kUsage;
  } catch (const std::exception& e) {
    fmt::print(stderr, "rtm: {}\n", e.what());
    return kFailed;
  } catch (const CORBA::Exception& e) {
    fmt::print(stderr, "rtm: {}\n", corba_name(e));
    return kFailed;
  }
  return kUsage;
}
