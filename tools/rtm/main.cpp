// SPDX-License-Identifier: Apache-2.0
// rtm: the command-line component browser and system launcher.
//
//   rtm ls [path] [-l] [--clean]          the naming tree: components, state, period, ports
//   rtm cat <comp>                        one component as it describes itself: ports with
//                                         their elements and units, subscriptions, counters,
//                                         timing, statistics, parameters
//   rtm set <comp> <param> <value>...     change a parameter (live, or while off)
//   rtm connect|disconnect <out> <in>     subscribe/unsubscribe (RTM.idl), --once, --policy
//   rtm on|off|reset <comp>...            reset: leave COMPONENT_ERROR (RTMExt)
//   rtm get <comp>.<out>                  pull one datum
//   rtm put <comp>.<in> <values>...       inject one datum (--rate HZ [--for S]: again and again)
//   rtm watch <comp>.<out>                stream a port live (--rate, --csv, --count, --duration)
//   rtm record <comp>.<out>... -o F.mcap  record ports into MCAP (--all, --duration, --count;
//                                         --recover DAMAGED: a recording that was not closed)
//   rtm play F.mcap                       put a recording into InPorts at its pace (--map, --rate,
//                                         --loop, --from/--to)
//   rtm replay PROGRAM LOG.mcap [-- OPTS]  a component's logic again against its cycle log
//                                         (--log-cycles), outputs compared byte for byte
//   rtm up <system.yaml> [--set NAME] / rtm down <system.yaml|name>
//   rtm names [--stop]                    a naming service of one's own on loopback: prints
//                                         `export RTM_NAMING=…` (eval "$(rtm names)")
//   rtm tls init <folder> / rtm tls issue <authority> <folder>   certificates across hosts
//   rtm new component <name> [--in n:Type]... [--out n:Type]...  a project of your own
//   rtm serve [--listen 127.0.0.1:PORT]   the component editor in a browser (serve.h)
//   rtm demo [demo options]               the force-servo demo on the simulator (installed examples)
//   rtm script FILE [ARGS...]             a motion script (Python) as the servo's reference
//                                         generator: exec's $RTM_SCRIPT_PYTHON (/usr/bin/python3)
//                                         -m rtm.script [--naming, --tls, --timeout as given to
//                                         rtm] FILE ARGS..., `import rtm` found beside rtm
//
// Every command takes --naming host:port (or $RTM_NAMING), --tls folder (or $RTM_TLS) and
// --json; exit code 0 ok, 1 failed, 2 usage.
#include "browser/browser.h"
#include "launcher/launcher.h"
#include "launcher/timing_check.h"
#include "launcher/private_naming.h"
#include "report.h"
#include "launcher/system_file.h"
#include "new_command.h"
#include "play_command.h"
#include "record_command.h"
#include "replay_command.h"
#include "serve/serve.h"
#include "tls_command.h"
#include "browser/values.h"
#include "watch.h"

#include "host/access.h"
#include "rtm/data.h"
#include "rtm/log.h"
#include "rtm/orb.h"
#include "host/tls.h"
#include "rt/clock.h"
#include "rt/schedule.h"

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <cerrno>
#include <cstring>
#include <optional>

#include <unistd.h>

namespace {

namespace fs = std::filesystem;
using namespace rtm::cli;
using nlohmann::json;

constexpr int kOk = 0, kFailed = 1, kUsage = 2, kInterrupted = 130;  // 130: 128 + SIGINT, as shells do

std::atomic<bool> g_interrupted{false};
extern "C" void on_interrupt(int) { g_interrupted.store(true); }

// Turns any failure into a one-line message and the exit code.
class Failure : public std::runtime_error {
 public:
  Failure(const std::string& what, int code) : std::runtime_error(what), code(code) {}
  int code;
};

std::string corba_name(const CORBA::Exception& e) { return failure_text(e); }

// Every subcommand and the variables its options are bound to.
struct Cli {
  std::string naming;
  std::string tls;  // TLS folder for giop:ssl: endpoints
  bool json = false;
  int timeout_ms = 5000;  // on() of a composite makes several remote calls of its own
  CLI::App *ls = nullptr, *cat = nullptr, *set = nullptr, *connect = nullptr, *disconnect = nullptr, *on = nullptr,
           *off = nullptr, *reset = nullptr, *get = nullptr, *put = nullptr, *watch = nullptr, *up = nullptr,
           *down = nullptr, *serve = nullptr, *names = nullptr, *demo = nullptr, *check = nullptr,
           *script = nullptr;
  CLI::Option* timeout_option = nullptr;  // given or not: rtm script passes it on only when given
  bool names_stop = false;
  std::string ls_path;
  bool ls_long = false, ls_clean = false, ls_names = false;
  bool cat_names = false, cat_parameters = false;
  std::string component;  // cat, set
  std::string parameter;
  std::vector<std::string> values;  // set, put
  std::string conn_out, conn_in;
  bool conn_once = false;
  std::string conn_policy;
  std::vector<std::string> components;  // on, off, reset
  std::string port;                     // get, put, watch
  WatchOptions watch_options;
  double put_rate_hz = 0, put_for_s = 0;
  std::string up_file, down_what, up_set;
  int up_timeout_ms = 10000;
  bool up_force = false;
  std::string check_file;
  TlsCommand tls_command;
  NewCommand new_command;
  RecordCommand record_command;
  PlayCommand play_command;
  ReplayCommand replay_command;
  std::string listen = "127.0.0.1:0";
};

void add_browse_commands(CLI::App& app, Cli& c) {
  c.ls = app.add_subcommand("ls", "list components in the naming service");
  c.ls->add_option("path", c.ls_path, "what to list: a host, a component's name, or host/name");
  c.ls->add_flag("-l,--long", c.ls_long, "add lateness, overrun statistics and each component's own statistics");
  c.ls->add_flag("--clean", c.ls_clean, "remove bindings whose process is gone");
  c.ls->add_flag("--names", c.ls_names, "only the names, one per line (for scripts and completion)");
  c.cat = app.add_subcommand("cat", "show one component as it describes itself: ports, units, statistics, parameters");
  c.cat->add_option("component", c.component, "name or host/name")->required();
  c.cat->add_flag("--names", c.cat_names, "only the port names, one per line (for scripts and completion)");
  c.cat->add_flag("--parameters", c.cat_parameters, "only the parameter names, one per line");
  c.set = app.add_subcommand("set", "change a component's parameter (live ones at once, others while it is off)");
  c.set->add_option("component", c.component, "name or host/name")->required();
  c.set->add_option("parameter", c.parameter, "the parameter's name (`rtm cat` lists them)")->required();
  c.set->add_option("values", c.values, "the new value: one number, or several (6 gains)")
      ->required()
      ->allow_extra_args();
}

void add_wiring_commands(CLI::App& app, Cli& c) {
  c.connect = app.add_subcommand("connect", "subscribe an InPort to an OutPort");
  c.disconnect = app.add_subcommand("disconnect", "unsubscribe an InPort from an OutPort");
  for (auto* sub : {c.connect, c.disconnect}) {
    sub->add_option("out", c.conn_out, "<component>.<OutPort>")->required();
    sub->add_option("in", c.conn_in, "<component>.<InPort>")->required();
    sub->add_flag("--once", c.conn_once, "a once subscription (next datum only) instead of repeated");
  }
  c.connect->add_option("--policy", c.conn_policy,
                        "the connection's policy, e.g. \"reader=fifo:16 depth=32 delivery=thread call=500ms\" "
                        "(docs/connections.md)");
  c.on = app.add_subcommand("on", "start components' activities");
  c.off = app.add_subcommand("off", "stop components' activities");
  c.reset = app.add_subcommand("reset", "take components out of the error state (then `on`)");
  for (auto* sub : {c.on, c.off, c.reset}) sub->add_option("components", c.components)->required();
}

void add_data_commands(CLI::App& app, Cli& c) {
  c.get = app.add_subcommand("get", "pull the latest datum of an OutPort");
  c.get->add_option("port", c.port, "<component>.<OutPort>")->required();
  c.put = app.add_subcommand("put", "send one datum to an InPort");
  c.put->add_option("port", c.port, "<component>.<InPort>")->required();
  c.put->add_option("values", c.values, "the values (6 for TimedFloat6)")->required()->allow_extra_args();
  CLI::Option* rate = c.put->add_option("--rate", c.put_rate_hz,
                    "put it again and again, freshly stamped, at this rate (Hz, 1 to 10000) on a fixed grid of the "
                    "monotonic clock; until --for is over or Ctrl-C")
      ->check(CLI::Range(1.0, 10000.0));
  c.put->add_option("--for", c.put_for_s, "with --rate: for this long (s)")->check(CLI::PositiveNumber)->needs(rate);
  c.watch = app.add_subcommand("watch", "stream an OutPort's data live");
  auto& w = c.watch_options;
  c.watch->add_option("port", c.port, "<component>.<OutPort>")->required();
  c.watch->add_option("--rate", w.rate_hz, "display refresh rate, Hz")->check(CLI::PositiveNumber);
  c.watch->add_option("--csv", w.csv_path, "also write every datum to this CSV file");
  c.watch->add_option("--count", w.count, "stop after this many data");
  c.watch->add_option("--duration", w.duration_s, "stop after this many seconds");
}

void add_system_commands(CLI::App& app, Cli& c) {
  c.up = app.add_subcommand("up", "launch a system file's components, connect and turn them on");
  c.up->add_option("file", c.up_file, "system file (YAML)")->required();
  c.up->add_option("--bind-timeout", c.up_timeout_ms, "ms to wait for each component to bind");
  c.up->add_option("--set", c.up_set, "a parameter set of the file: its values over the components' parameters");
  c.up->add_flag("--force", c.up_force, "start a system whose timing contracts the analysis says it cannot keep "
                                         "(each refusal is printed first)");
  c.check = app.add_subcommand("check", "check a system file's timing contracts before it starts: per CPU, per "
                                        "component and each chain hop by hop (exit 1: it cannot keep them)");
  c.check->add_option("file", c.check_file, "system file (YAML)")->required();
  c.down = app.add_subcommand("down", "stop a system started by `rtm up`");
  c.serve = app.add_subcommand("serve", "the component editor in a browser: prints its URL, serves until Ctrl-C");
  c.serve->add_option("--listen", c.listen, "HOST:PORT to listen on (port 0: any free one)")->capture_default_str();
  c.down->add_option("system", c.down_what, "the system file, or the system's name")->required();
  c.names = app.add_subcommand("names", "start (or find running) a naming service of your own on loopback; prints "
                                        "`export RTM_NAMING=...` for eval \"$(rtm names)\"");
  c.names->add_flag("--stop", c.names_stop, "stop it and remove its data");
  c.demo = app.add_subcommand("demo", "the force-servo demo on the simulated PA10, from the installed examples "
                                      "(`rtm demo --help` lists its options)");
  c.demo->prefix_command();  // every word after it, --help too, is the demo's
  c.demo->set_help_flag();
  c.script = app.add_subcommand(
      "script",
      "run a motion script (docs/python.md, \"Motion scripts\") as the servo's reference generator: rtm script FILE "
      "[--name NAME] [--reference PORT] [--wrench PORT] [--pose PORT] [--controller NAME]; rtm script --help-script "
      "lists the script's options");
  // FILE and every word after it, options too, are the script's; --help before FILE is rtm's.
  c.script->prefix_command();
}

// ------------------------------------------------------------------ commands

// `rtm check FILE`: exit 0 when the analysis finds the contracts kept (warnings say what it
// cannot bound), 1 when it refuses them, 2 for a malformed file.
int run_check(const Cli& c) {
  TimingCheck check;
  try {
    check = check_timing(SystemFile::load(c.check_file));
  } catch (const SystemFileError& e) {
    throw Failure(e.what(), kUsage);
  }
  if (c.json)
    fmt::print("{}\n", timing_check_json(check));
  else {
    for (const auto& name : check.without_loop) fmt::print("{}: runs no loop of its own (a composite): no contract\n", name);
    fmt::print("{}", check.analysis.explain());
  }
  return check.analysis.refused() ? kFailed : kOk;
}

int run_ls(const Browser& browser, const Cli& c) {
  if (c.ls_clean) {
    const auto removed = browser.clean(c.ls_path);
    if (c.json) {
      json j = json::array();
      for (const auto& p : removed) j.push_back(p.to_string());
      fmt::print("{}\n", json{{"removed", j}}.dump());
    } else {
      for (const auto& p : removed) fmt::print("removed dead binding {}\n", terminal_text(p.to_string()));
      if (removed.empty()) fmt::print("no dead bindings\n");
    }
    return kOk;
  }
  const auto comps = browser.list(c.ls_path, c.ls_long);
  if (c.ls_names) {
    for (const auto& comp : comps) fmt::print("{}\n", terminal_text(comp.path.name));
  } else if (c.json) {
    json j = json::array();
    for (const auto& comp : comps) j.push_back(component_json(comp, c.ls_long));
    fmt::print("{}\n", j.dump(2));
  } else {
    print_ls(comps, c.ls_long);
  }
  return kOk;
}

int run_cat(const Browser& browser, const Cli& c) {
  const auto info = browser.describe(c.component);
  if (c.cat_names || c.cat_parameters) {
    if (c.cat_names)
      for (const auto& p : info.ports) fmt::print("{}\n", terminal_text(p.name));
    if (c.cat_parameters)
      for (const auto& p : info.parameters) fmt::print("{}\n", terminal_text(p.name));
  } else if (c.json) {
    fmt::print("{}\n", component_json(info, true).dump(2));
  } else {
    print_cat(info);
  }
  return kOk;
}

int run_set(const Browser& browser, const Cli& c) {
  std::string value;
  for (const auto& v : c.values) value += (value.empty() ? "" : " ") + v;
  const std::string now = browser.set_parameter(c.component, c.parameter, value);
  if (c.json) {
    fmt::print("{}\n", json{{"component", c.component}, {"parameter", c.parameter}, {"value", now}}.dump());
  } else {
    fmt::print("{}.{} = {}\n", c.component, c.parameter, terminal_text(now));
  }
  return kOk;
}

int run_connect(const Browser& browser, const Cli& c) {
  const PortAddress o = PortAddress::parse(c.conn_out), i = PortAddress::parse(c.conn_in);
  // std::invalid_argument (a usage error) for a bad policy, or one that says repeated beside --once.
  const rtm::ConnPolicy policy =
      rtm::parse_conn_policy(c.conn_policy, c.conn_once ? std::optional<bool>(true) : std::nullopt);
  const bool connecting = c.connect->parsed();
  if (connecting) {
    browser.connect(o, i, policy);
  } else {
    browser.disconnect(o, i, policy.once ? RTM::once : RTM::repeated);
  }
  const char* verb = connecting ? "connected" : "disconnected";
  const char* kind = policy.once ? "once" : "repeated";
  if (c.json) {
    json j{{"from", o.to_string()}, {"to", i.to_string()}, {"type", kind}};
    if (connecting) j["policy"] = rtm::to_string(policy);
    fmt::print("{}\n", json{{verb, j}}.dump());
  } else if (connecting && policy != rtm::ConnPolicy::repeated() && policy != rtm::ConnPolicy::one_shot()) {
    fmt::print("{} {} -> {} ({})\n", verb, o.to_string(), i.to_string(), rtm::to_string(policy));
  } else {
    fmt::print("{} {} -> {} ({})\n", verb, o.to_string(), i.to_string(), kind);
  }
  return kOk;
}

int run_switch(const Browser& browser, const Cli& c) {
  const char* verb = c.on->parsed() ? "on" : c.off->parsed() ? "off" : "reset";
  int code = kOk;
  json results = json::object();
  const Switch what = c.on->parsed() ? Switch::on : c.off->parsed() ? Switch::off : Switch::reset;
  for (const auto& name : c.components) {
    try {
      browser.switch_component(name, what);
      results[name] = "ok";
      if (!c.json) fmt::print("{} {}\n", verb, name);
    } catch (const BrowseError& e) {
      results[name] = e.what();
      code = kFailed;
      if (!c.json) fmt::print(stderr, "rtm: {}\n", terminal_text(e.what()));
    }
  }
  if (c.json) fmt::print("{}\n", results.dump());
  return code;
}

int run_get(const Browser& browser, const Cli& c) {
  const ResolvedPort p = browser.port(PortAddress::parse(c.port));
  if (p.direction != Direction::out) throw Failure(p.address + " is an InPort; get reads OutPorts", kFailed);
  RTM::OutPort_var out = RTM::OutPort::_narrow(p.object);
  CORBA::Any_var value;
  try {
    value = out->get();
  } catch (const CORBA::BAD_INV_ORDER& e) {
    if (e.minor() == rtm::kMinorNoDataYet) throw Failure(p.address + " has no data yet", kFailed);
    throw;
  }
  if (c.json) {
    json j = format_json(value.in());
    j["port"] = p.address;
    fmt::print("{}\n", j.dump());
  } else {
    fmt::print("{}\n", terminal_text(format_text(value.in(), p.units(), p.names())));
  }
  return kOk;
}

// --rate: one put per period of the grid (rt/schedule.h: a late put does not shift it; puts
// missed by more than a period are skipped and counted), each datum stamped when it is made.
// A put that fails is counted and the next one tried; the summary says how many went.
int put_repeatedly(const ResolvedPort& p, RTM::InPort_ptr in, const Cli& c) {
  const auto period_ns = static_cast<std::int64_t>(std::llround(1e9 / c.put_rate_hz));
  rtm::PeriodicSchedule schedule(period_ns);
  const std::int64_t start_ns = rtm::monotonic_ns();
  const std::int64_t end_ns =
      c.put_for_s > 0 ? start_ns + static_cast<std::int64_t>(c.put_for_s * 1e9) : std::numeric_limits<std::int64_t>::max();
  schedule.start(0, start_ns);
  std::uint64_t sent = 0, failed = 0;
  std::string last_failure;
  while (!g_interrupted.load()) {
    rtm::sleep_until_ns(schedule.deadline_ns());
    const std::int64_t wake_ns = rtm::monotonic_ns();
    if (wake_ns >= end_ns || g_interrupted.load()) break;
    schedule.begin(wake_ns);
    try {
      in->put(parse_value(p.type, c.values));
      ++sent;
    } catch (const CORBA::Exception& e) {
      ++failed;
      last_failure = corba_name(e);
    }
    schedule.end(rtm::monotonic_ns());
  }
  const double seconds = static_cast<double>(rtm::monotonic_ns() - start_ns) / 1e9;
  const rtm::ActivityStats stats = schedule.stats();
  if (c.json) {
    fmt::print("{}\n", json{{"port", p.address}, {"put", sent}, {"failed", failed}, {"skipped", stats.skipped},
                            {"seconds", seconds}, {"rate_hz", c.put_rate_hz},
                            {"lateness_p99_us", stats.lateness_p99_ns / 1000}}
                           .dump());
  } else {
    fmt::print("put {} {} times in {:.2f} s at {} Hz ({} failed{}, {} skipped as late, lateness p99 {} us)\n",
               p.address, sent, seconds, c.put_rate_hz, failed,
               failed ? fmt::format(", the last: {}", last_failure) : std::string(), stats.skipped,
               stats.lateness_p99_ns / 1000);
  }
  return failed == 0 ? kOk : kFailed;
}

int run_put(const Browser& browser, const Cli& c) {
  const ResolvedPort p = browser.port(PortAddress::parse(c.port));
  if (p.direction != Direction::in) throw Failure(p.address + " is an OutPort; put writes InPorts", kFailed);
  CORBA::Any value;
  try {
    value = parse_value(p.type, c.values);
  } catch (const ValueError& e) {
    throw Failure(fmt::format("{}: {}", p.address, e.what()), kUsage);
  }
  RTM::InPort_var in = RTM::InPort::_narrow(p.object);
  if (c.put_rate_hz > 0) return put_repeatedly(p, in, c);
  in->put(value);
  if (c.json) {
    json j = format_json(value);
    j["port"] = p.address;
    fmt::print("{}\n", j.dump());
  } else {
    fmt::print("put {}  {}\n", p.address, terminal_text(format_text(value, p.units(), p.names())));
  }
  return kOk;
}

int run_up(const Browser& browser, const Cli& c, const SystemFile& system, const rtm::NamingAddress& naming,
           const LaunchOptions& launch) {
  const SystemState state = system_up(system, browser, naming, launch);
  if (c.json) {
    json procs = json::array();
    for (const auto& p : state.processes)
      procs.push_back({{"name", p.name}, {"pid", p.pid}, {"log", p.log.string()}, {"members", p.members}});
    fmt::print("{}\n", json{{"system", state.system}, {"processes", procs}}.dump());
  } else {
    std::size_t components = 0;
    for (const auto& p : state.processes) components += p.members.size();
    const std::string processes = components == state.processes.size() ? ""
                                  : state.processes.size() == 1  ? std::string(" in one process")
                                                                 : fmt::format(" in {} processes", state.processes.size());
    fmt::print("system {} is up ({} components{}); `rtm down {}` stops it\n", state.system, components, processes,
               state.system);
  }
  return kOk;
}

// The user's own naming service: started or found, its address as a shell line on stdout (the
// rest on stderr, so that eval "$(rtm names)" takes only the export); or stopped.
int run_names(const Cli& c) {
  if (c.names_stop) {
    const auto stopped = private_naming_down();
    if (c.json) {
      fmt::print("{}\n", json{{"stopped", stopped.has_value()},
                              {"address", stopped ? stopped->address.to_string() : std::string()}}
                             .dump());
    } else if (stopped) {
      fmt::print("stopped the naming service on {} (pid {})\n", stopped->address.to_string(), stopped->process.pid);
    } else {
      fmt::print("no naming service of yours was running\n");
    }
    return kOk;
  }
  const PrivateNaming n = private_naming_up();
  if (c.json) {
    fmt::print("{}\n",
               json{{"address", n.address.to_string()}, {"pid", n.process.pid}, {"started", n.started}}.dump());
    return kOk;
  }
  fmt::print(stderr, "naming service {} on {} (pid {}; `rtm names --stop` stops it)\n",
             n.started ? "started" : "running", n.address.to_string(), n.process.pid);
  fmt::print("export RTM_NAMING={}\n", n.address.to_string());
  return kOk;
}

int run_down(const Browser& browser, const Cli& c, const LaunchOptions& launch) {
  std::string name = c.down_what;
  if (std::filesystem::exists(c.down_what) && std::filesystem::is_regular_file(c.down_what)) {
    name = SystemFile::load(c.down_what).name;
  }
  const SystemState state = SystemState::load(name);
  const auto killed = system_down(state, &browser, launch);
  if (c.json) {
    fmt::print("{}\n", json{{"system", state.system}, {"killed", killed}}.dump());
  } else {
    for (const auto& k : killed) fmt::print("{} did not stop on SIGTERM: killed\n", k);
    fmt::print("system {} is down\n", state.system);
  }
  return kOk;
}

int run_serve(const Browser& browser, const Cli& c) {
  ServeOptions options;
  try {
    options = parse_listen(c.listen);
  } catch (const std::invalid_argument& e) {
    throw Failure(e.what(), kUsage);
  }
  const bool loopback = options.host == "127.0.0.1" || options.host == "::1" || options.host == "localhost";
  if (!loopback) {
    fmt::print(stderr, "rtm serve: warning: listening on {}, not loopback: whoever reaches it and has the token can "
                       "move the arm; the token crosses the network in clear\n", options.host);
  }
  WebServer server(browser, options);
  server.run([] { return g_interrupted.load(); }, [](const std::string& url) {
    fmt::print("{}\n", url);
    std::fflush(stdout);
  });
  return kOk;
}

// --naming, else the system file's (unless $RTM_NAMING is set), else $RTM_NAMING or the default.
rtm::NamingAddress naming_address(const Cli& c, const std::optional<SystemFile>& system) {
  try {
    if (!c.naming.empty()) return rtm::NamingAddress::parse(c.naming);
    if (system && system->naming && !std::getenv("RTM_NAMING")) return rtm::NamingAddress::parse(*system->naming);
    return rtm::NamingAddress::from_environment();
  } catch (const std::invalid_argument& e) {
    throw Failure(e.what(), kUsage);
  }
}

// Runs the force-servo demo installed beside this rtm (<prefix>/share/rtm/examples/force-servo/demo,
// copied there in a build tree too) with this rtm's folder as the programs' one. Returns only
// when it cannot be run.
int run_demo(const Cli& c) {
  std::error_code ec;
  const fs::path bin = fs::read_symlink("/proc/self/exe", ec).parent_path();
  if (ec) throw Failure("rtm demo: cannot tell where rtm is installed: " + ec.message(), kFailed);
  const fs::path script = bin.parent_path() / "share/rtm/examples/force-servo/demo";
  if (::access(script.c_str(), X_OK) != 0)
    throw Failure(fmt::format("rtm demo: {} is missing or not executable (it is installed with rtm)", script.string()),
                  kFailed);
  std::vector<std::string> args{script.string(), "--bin", bin.string()};
  for (const auto& word : c.demo->remaining()) args.push_back(word);
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::fflush(stdout);
  ::setenv("RTM_DEMO_COMMAND", "rtm demo", 1);  // what its --help calls it
  ::execv(script.c_str(), argv.data());
  throw Failure(fmt::format("rtm demo: cannot run {}: {}", script.string(), std::strerror(errno)), kFailed);
}

// ------------------------------------------------------------------ script

// The Python interpreter rtm script runs: $RTM_SCRIPT_PYTHON, else Debian's python3 (the one
// RTM's Python module is built for).
constexpr const char* kScriptPythonVariable = "RTM_SCRIPT_PYTHON";
constexpr const char* kScriptPython = "/usr/bin/python3";

// Where `import rtm` is found for the rtm in folder bin: an installed tree's
// <prefix>/lib/python3/dist-packages when it exists, else a build tree's <build>/python when it
// holds the package (build/default/bin/rtm -> build/default/python); empty when neither.
fs::path python_package_dir(const fs::path& bin) {
  std::error_code ec;
  const fs::path installed = bin.parent_path() / RTM_PYTHON_INSTALL_DIR;
  if (fs::is_directory(installed, ec)) return installed;
  const fs::path build = bin.parent_path() / "python";
  if (fs::is_regular_file(build / "rtm" / "__init__.py", ec)) return build;
  return {};
}

// `rtm script FILE [ARGS...]`: exec's python3 -m rtm.script FILE ARGS... with the package found
// beside this rtm first on PYTHONPATH. rtm's own --naming, --tls and --timeout, when given, go
// first on its command line, as `rtm up` gives a component --naming (rtm.script's --timeout is
// in seconds); the same options among ARGS come later and win. Returns only when it cannot be
// run.
int run_script(const Cli& c) {
  std::vector<std::string> words = c.script->remaining();
  if (words.empty())
    throw Failure("rtm script: which script? rtm script FILE [ARGS...] (rtm script --help-script lists the script's "
                  "options)",
                  kUsage);
  if (words.front() == "--help-script") words.front() = "--help";  // rtm.script's own help
  const char* chosen = std::getenv(kScriptPythonVariable);
  const std::string python = chosen != nullptr && *chosen != '\0' ? chosen : kScriptPython;
  const std::string needs = fmt::format(
      "rtm script needs {} and RTM's Python package (python3-numpy): scripts/deps.sh installs them", python);
  if (::access(python.c_str(), X_OK) != 0) throw Failure(needs, kUsage);

  std::error_code ec;
  const fs::path bin = fs::read_symlink("/proc/self/exe", ec).parent_path();
  if (!ec) {
    if (const fs::path package = python_package_dir(bin); !package.empty()) {
      const char* before = std::getenv("PYTHONPATH");
      const std::string path =
          package.string() + (before != nullptr && *before != '\0' ? ":" + std::string(before) : std::string());
      ::setenv("PYTHONPATH", path.c_str(), 1);
    }
  }
  std::vector<std::string> args{python, "-m", "rtm.script"};
  if (!c.naming.empty()) args.insert(args.end(), {"--naming", c.naming});
  if (!c.tls.empty()) args.insert(args.end(), {"--tls", c.tls});
  if (c.timeout_option->count() > 0) args.insert(args.end(), {"--timeout", fmt::format("{:g}", c.timeout_ms / 1000.0)});
  args.insert(args.end(), words.begin(), words.end());
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::fflush(stdout);
  ::execv(python.c_str(), argv.data());
  throw Failure(fmt::format("{} (running it failed: {})", needs, std::strerror(errno)), kUsage);
}

int run(const Cli& c) {
  if (c.demo->parsed()) return run_demo(c);
  if (c.script->parsed()) return run_script(c);
  if (c.tls_command.parsed()) {
    c.tls_command.run(c.json);
    return kOk;
  }
  if (c.new_command.parsed()) {
    c.new_command.run(c.json);
    return kOk;
  }
  if (c.names->parsed()) return run_names(c);
  if (c.check->parsed()) return run_check(c);
  if (c.record_command.recovers()) return c.record_command.run_recover(c.json);
  if (c.replay_command.parsed()) return c.replay_command.run(c.json);
  if (!c.tls.empty()) {
    try {
      rtm::configure_tls(rtm::check_tls_folder(c.tls));
    } catch (const std::runtime_error& e) {
      throw Failure(std::string("--tls: ") + e.what(), kFailed);
    }
    ::setenv(rtm::kTlsFolderVariable, c.tls.c_str(), 1);  // what `rtm up` starts uses it too
  }
  std::optional<SystemFile> system;
  if (c.up->parsed()) system = SystemFile::load(c.up_file);
  const rtm::NamingAddress naming = naming_address(c, system);
  rtm::configure_access(rtm::AccessPolicy::owner);  // rtm watch's InPorts: this user's data only
  rtm::Orb orb(client_orb_arguments(naming, !c.tls.empty(), c.timeout_ms));
  const Browser browser(orb.orb(), naming, std::chrono::milliseconds(c.timeout_ms));
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);
  LaunchOptions launch;
  launch.bind_timeout = std::chrono::milliseconds(c.up_timeout_ms);
  launch.parameter_set = c.up_set;
  launch.force = c.up_force;
  if (!c.json) {
    launch.progress = [](const std::string& line) {
      fmt::print("{}\n", line);
      std::fflush(stdout);  // one line per step as it happens, into a pipe or log too
    };
  }
  launch.interrupted = [] { return g_interrupted.load(); };

  if (c.ls->parsed()) return run_ls(browser, c);
  if (c.cat->parsed()) return run_cat(browser, c);
  if (c.set->parsed()) return run_set(browser, c);
  if (c.connect->parsed() || c.disconnect->parsed()) return run_connect(browser, c);
  if (c.on->parsed() || c.off->parsed() || c.reset->parsed()) return run_switch(browser, c);
  if (c.get->parsed()) return run_get(browser, c);
  if (c.put->parsed()) return run_put(browser, c);
  if (c.watch->parsed()) return watch(browser, orb, c.port, c.watch_options, g_interrupted);
  if (c.record_command.parsed()) return c.record_command.record(browser, orb, c.json, g_interrupted);
  if (c.play_command.parsed()) return c.play_command.run(browser, c.json, g_interrupted);
  if (c.up->parsed()) return run_up(browser, c, *system, naming, launch);
  if (c.down->parsed()) return run_down(browser, c, launch);
  if (c.serve->parsed()) return run_serve(browser, c);
  return kUsage;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"rtm: browse, wire and launch RT components"};
  app.require_subcommand(1);
  Cli c;
  app.add_option("--naming", c.naming, "naming service host:port (default $RTM_NAMING or 127.0.0.1:2809)");
  app.add_flag("--json", c.json, "machine-readable output");
  app.add_option("--tls", c.tls, "TLS folder (`rtm tls init`): reach giop:ssl: endpoints with its certificate")
      ->envname(rtm::kTlsFolderVariable);
  c.timeout_option =
      app.add_option("--timeout", c.timeout_ms, "bound on each remote call, ms")->check(CLI::PositiveNumber);
  add_browse_commands(app, c);
  add_wiring_commands(app, c);
  add_data_commands(app, c);
  add_system_commands(app, c);
  c.tls_command.add_to(app);
  c.new_command.add_to(app);
  c.record_command.add_to(app);
  c.play_command.add_to(app);
  c.replay_command.add_to(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? kOk : kUsage;
  }
  c.watch_options.json = c.json;
  rtm::log().set_level(spdlog::level::warn);
  try {
    return run(c);
  } catch (const Failure& e) {
    fmt::print(stderr, "rtm: {}\n", terminal_text(e.what()));
    return e.code;
  } catch (const LaunchInterrupted& e) {
    fmt::print(stderr, "rtm: {}\n", terminal_text(e.what()));
    return kInterrupted;
  } catch (const std::invalid_argument& e) {
    fmt::print(stderr, "rtm: {}\n", terminal_text(e.what()));
    return kUsage;
  } catch (const std::exception& e) {
    fmt::print(stderr, "rtm: {}\n", terminal_text(e.what()));
    return kFailed;
  } catch (const CORBA::Exception& e) {
    fmt::print(stderr, "rtm: {}\n", corba_name(e));
    return kFailed;
  }
}
