// SPDX-License-Identifier: Apache-2.0
#include "host/runner.h"

#include "host/lease.h"
#include "runner_parts.h"
#include "host/name_binding.h"
#include "host/tls.h"
#include "rtm/log.h"
#include "rtm/orb.h"

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <pthread.h>
#include <sched.h>
#include <signal.h>
#include <unistd.h>

#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <tuple>
#include <utility>

namespace rtm {

namespace detail {

const char* program_name(const char* argv0) {
  const char* slash = std::strrchr(argv0, '/');
  return slash != nullptr ? slash + 1 : argv0;
}

TerminationSignals::TerminationSignals() {
  sigemptyset(&set_);
  sigaddset(&set_, SIGINT);
  sigaddset(&set_, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &set_, &previous_);
  // A peer that vanishes mid-write must not kill us.
  ::signal(SIGPIPE, SIG_IGN);
}

TerminationSignals::~TerminationSignals() { pthread_sigmask(SIG_SETMASK, &previous_, nullptr); }

int TerminationSignals::wait() const {
  int received = 0;
  while (sigwait(&set_, &received) != 0) {
  }
  return received;
}

void pin_process_to_cpu(int cpu) {
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  // Before any thread exists: the ORB's threads and the activity inherit it.
  if (sched_setaffinity(0, sizeof(set), &set) != 0) {
    log().warn("cannot pin to CPU {}: {}; running unpinned", cpu, std::strerror(errno));
  }
}

}  // namespace detail

PeriodicOptions RunSettings::periodic_options() const {
  PeriodicOptions options;
  options.period_ns = period_ns;
  options.fifo_priority = rt_priority;
  options.cpu = cpu;
  options.lock_memory = lock_memory;
  options.thread_name = name;
  // A first deadline in the past on the grid k * period + phase: the activity joins that grid
  // at every start, and so does every component of the host with the same period and a phase.
  if (phase_ns) options.first_deadline_ns = period_ns + *phase_ns;
  if (sched_runtime_ns > 0) {
    // Due at the end of the period: a shorter deadline is throttled off this grid (docs/timing.md).
    options.fifo_priority = 0;
    options.deadline_runtime_ns = sched_runtime_ns;
  }
  return options;
}

TimingContract RunSettings::contract() const {
  TimingContract c;
  c.component = name;
  c.period_ns = period_ns;
  c.phase_ns = phase_ns;
  c.deadline_ns = deadline_ns > 0 ? deadline_ns : period_ns;
  c.budget_ns = budget_ns;
  c.await_ns = await_port.empty() ? 0 : await_bound_ns;
  c.await_port = await_port;
  c.cpu = cpu;
  c.sched = sched_runtime_ns > 0 ? SchedClass::deadline : rt_priority > 0 ? SchedClass::fifo : SchedClass::other;
  c.fifo_priority = c.sched == SchedClass::fifo ? rt_priority : 0;
  c.runtime_ns = sched_runtime_ns;
  c.on_miss = on_miss;
  return c;
}

std::string contract_json(const TimingContract& c) {
  // Names follow the rule "lower-case letters, digits, '_'": nothing to escape.
  return fmt::format(
      R"({{"component":"{}","period_ns":{},"phase_ns":{},"deadline_ns":{},"budget_ns":{},"await_ns":{},"await_port":"{}",)"
      R"("cpu":{},"sched":"{}","fifo_priority":{},"runtime_ns":{},"on_miss":"{}"}})",
      c.component, c.period_ns, c.phase_ns ? std::to_string(*c.phase_ns) : std::string("null"), c.effective_deadline_ns(),
      c.budget_ns, c.await_ns, c.await_port, c.cpu, sched_class_name(c.sched), c.fifo_priority, c.runtime_ns,
      miss_action_name(c.on_miss));
}

std::int64_t parse_period_ns(std::string_view text) {
  const std::optional<double> ns = parse_duration_ns(text);
  // Under 50 us a cycle would be shorter than waking a thread costs on these machines.
  if (!ns || *ns < 50e3 || *ns > 3600e9) {
    throw std::invalid_argument(fmt::format("period '{}': want a duration from 50us to 1 h, e.g. 2ms, 500us, 0.002s", text));
  }
  return std::llround(*ns);
}

std::pair<std::string, std::int64_t> parse_await(std::string_view text, std::int64_t period_ns) {
  const std::size_t colon = text.find(':');
  const std::string port(text.substr(0, colon));
  if (port.empty()) throw std::invalid_argument(fmt::format("await '{}': want PORT[:BOUND], e.g. in0:0.2ms", text));
  if (colon == std::string_view::npos) return {port, period_ns / 10};
  const std::string_view bound_text = text.substr(colon + 1);
  const std::optional<double> ns = parse_duration_ns(bound_text);
  if (!ns || std::llround(*ns) <= 0 || std::llround(*ns) >= period_ns) {
    throw std::invalid_argument(fmt::format("await '{}': want a bound above 0 and below the period ({} us), e.g. 0.2ms",
                                            text, period_ns / 1000));
  }
  return {port, std::llround(*ns)};
}

std::int64_t parse_phase_ns(std::string_view text, std::int64_t period_ns) {
  const std::optional<double> ns = parse_duration_ns(text);
  if (!ns || *ns < 0 || std::llround(*ns) >= period_ns) {
    throw std::invalid_argument(fmt::format(
        "phase '{}': want a duration from 0 to less than the period ({} us), e.g. 0.5ms", text, period_ns / 1000));
  }
  return std::llround(*ns);
}

SplitArguments split_orb_arguments(int argc, const char* const* argv) {
  SplitArguments split;
  for (int i = 0; i < argc; ++i) {
    const std::string_view arg(argv[i]);
    if (i > 0 && arg.starts_with("-ORB") && arg.size() > 4) {
      split.orb.emplace_back(arg);
      if (i + 1 < argc) split.orb.emplace_back(argv[++i]);
    } else {
      split.own.emplace_back(arg);
    }
  }
  return split;
}

namespace detail {

// Started under chrt (SCHED_FIFO or SCHED_RR inherited): the activity keeps that priority
// (unless --rt-priority says otherwise), and so does every thread a datum passes on its way
// (set_path_thread_priority): the CAN listeners' receive threads, the OutPorts' delivery
// threads, and an ORB thread while it serves a put from a caller the access screen knows
// (host/access.cpp). Every other request is served at SCHED_OTHER, so that one that costs much
// CPU cannot starve the loops or the machine. The main thread is switched back before any
// other thread exists.
int keep_real_time_for_the_activity(const std::string& name) {
  int policy = SCHED_OTHER;
  sched_param param{};
  if (pthread_getschedparam(pthread_self(), &policy, &param) != 0) return 0;
  if (policy != SCHED_FIFO && policy != SCHED_RR) return 0;
  const sched_param other{};
  if (pthread_setschedparam(pthread_self(), SCHED_OTHER, &other) != 0) return 0;
  log().info("{}: started with real-time priority {}: kept for its activities, its CAN receive and delivery threads "
             "and the ORB's while they serve a put of this user's; other requests at SCHED_OTHER",
             name, param.sched_priority);
  return param.sched_priority;
}

// The options every OutPort of the component takes from the command line, as given.
// --period, --phase, --await as given, checked once the command line is parsed.
struct ScheduleTexts {
  std::string period = "2ms";
  std::string phase;
  std::string await;
};

void add_schedule_options(CLI::App& app, ScheduleTexts& texts) {
  app.add_option("--period", texts.period, "cycle period, 50us to 1h: 2ms, 500us, 0.002s")->capture_default_str();
  app.add_option("--phase", texts.phase,
                 "run each cycle this long after a multiple of the period on CLOCK_MONOTONIC (0 to less than "
                 "the period, e.g. 0.5ms): components of one host with the same period and a phase share one "
                 "grid, so a reader can run just after its writer")
      ->default_str("none: the first cycle runs when the component is turned on");
  app.add_option("--await", texts.await,
                 "PORT[:BOUND]: each cycle first waits for a new datum on this InPort (a name or in<k>), at most "
                 "BOUND after the cycle was due (default a tenth of the period), so that on a phase just after its "
                 "writer's a late writer costs that lateness, not a period");
}

// Throws std::invalid_argument naming a bad value.
void apply_schedule_texts(const ScheduleTexts& texts, RunSettings& settings) {
  settings.period_ns = parse_period_ns(texts.period);
  if (!texts.phase.empty()) settings.phase_ns = parse_phase_ns(texts.phase, settings.period_ns);
  if (!texts.await.empty()) std::tie(settings.await_port, settings.await_bound_ns) = parse_await(texts.await, settings.period_ns);
}

// The contract's options as given, checked once the command line is parsed.
struct ContractTexts {
  std::vector<std::string> chain_ends;
  std::vector<std::string> stamp_from;
  std::string deadline;
  std::string budget;
  std::string on_miss = "count";
  std::string sched_deadline;
  std::string watch = "on";
};

void add_contract_options(CLI::App& app, ContractTexts& texts, std::int64_t default_budget_ns, RunSettings& settings) {
  app.add_option("--deadline", texts.deadline,
                 "each cycle ends within this of its release (above 0, at most the period): watched, and "
                 "counted as missed_deadline (rtm ls -l, rtm cat)")
      ->default_str("the period");
  app.add_option("--budget", texts.budget,
                 "the longest one cycle may run, from its start (after --await) to its end: watched, and "
                 "counted as over_budget; `rtm check` adds it up per CPU")
      ->default_str(default_budget_ns > 0 ? format_duration(default_budget_ns) + " (this component's own)"
                                          : std::string("none declared"));
  app.add_option("--on-miss", texts.on_miss,
                 "what a cycle past its budget or deadline does besides being counted: count, warn (a "
                 "warning line, at most one a second) or brake (COMPONENT_ERROR: the component stops acting)")
      ->check(CLI::IsMember({"count", "warn", "brake"}))
      ->capture_default_str();
  app.add_option("--sched-deadline", texts.sched_deadline,
                 "run the activity under SCHED_DEADLINE, this runtime reserved every period and due at its "
                 "end (needs CAP_SYS_NICE; not with --rt-priority, --cpu or a --deadline below the period)");
  app.add_option("--watch-contract", texts.watch, "watch each cycle against the contract (on) or not (off)")
      ->check(CLI::IsMember({"on", "off"}))
      ->capture_default_str();
  app.add_option("--watch-chain", texts.chain_ends,
                 "NAME:PORT[:DEADLINE[:MAX_AGE[:ON_MISS]]]: this component ends chain NAME, whose data enter it "
                 "by InPort PORT: how old they are at each cycle's end (statistics chain.NAME.*), held to DEADLINE "
                 "at their first cycle and MAX_AGE at every cycle, a miss counted, warned or braked on; repeatable "
                 "(rtm up gives it from a system file's chains)")
      ->take_all();
  app.add_option("--stamp-from", texts.stamp_from,
                 "OUT=IN[+IN...]: each datum OutPort OUT writes carries the stamp of the newest datum InPort IN "
                 "gave (the oldest of several), so a chain's end sees how old its sample is without the component "
                 "copying tm; repeatable (rtm up gives it for each component inside a system file's chain)")
      ->take_all();
  app.add_flag("--print-contract", settings.print_contract,
               "print the timing contract these options give, as JSON, and exit (what `rtm check` reads)");
}

// "NAME:PORT[:DEADLINE[:MAX_AGE[:ON_MISS]]]"; std::invalid_argument saying what is wanted.
RunSettings::ChainEnd parse_chain_end(const std::string& text) {
  const auto bad = [&] {
    return std::invalid_argument(fmt::format("--watch-chain '{}': want NAME:PORT[:DEADLINE[:MAX_AGE[:ON_MISS]]], "
                                             "e.g. wrist_to_drive:twist:0.35ms:0:warn", text));
  };
  std::vector<std::string> parts;
  for (std::size_t from = 0;;) {
    const std::size_t colon = text.find(':', from);
    parts.push_back(text.substr(from, colon == std::string::npos ? std::string::npos : colon - from));
    if (colon == std::string::npos) break;
    from = colon + 1;
  }
  if (parts.size() < 2 || parts.size() > 5 || parts[0].empty() || parts[1].empty()) throw bad();
  RunSettings::ChainEnd end{parts[0], parts[1]};
  if (parts.size() == 5) {
    const std::optional<MissAction> on_miss = parse_miss_action(parts[4]);
    if (!on_miss) throw bad();
    end.on_miss = *on_miss;
    parts.pop_back();
  }
  for (std::size_t i = 2; i < parts.size(); ++i) {
    const std::optional<double> ns = parse_duration_ns(parts[i]);
    if (!ns || *ns < 0) throw bad();
    (i == 2 ? end.deadline_ns : end.max_age_ns) = std::llround(*ns);
  }
  return end;
}

// "OUT=IN[+IN...]"; std::invalid_argument saying what is wanted.
RunSettings::StampFrom parse_stamp_from(const std::string& text) {
  const std::size_t eq = text.find('=');
  RunSettings::StampFrom out;
  if (eq != std::string::npos) {
    out.out = text.substr(0, eq);
    for (std::size_t from = eq + 1;;) {
      const std::size_t plus = text.find('+', from);
      out.ins.push_back(text.substr(from, plus == std::string::npos ? std::string::npos : plus - from));
      if (plus == std::string::npos) break;
      from = plus + 1;
    }
  }
  const bool empty_in = std::any_of(out.ins.begin(), out.ins.end(), [](const auto& s) { return s.empty(); });
  if (out.out.empty() || out.ins.empty() || empty_in || out.ins.size() > OutPortBase::kMaxStampSources)
    throw std::invalid_argument(fmt::format("--stamp-from '{}': want OUT=IN[+IN...] (at most {} InPorts), e.g. twist=wrench",
                                            text, OutPortBase::kMaxStampSources));
  return out;
}

// Throws std::invalid_argument naming a bad value; after apply_schedule_texts().
void apply_contract_texts(const ContractTexts& texts, std::int64_t default_budget_ns, RunSettings& settings) {
  const auto duration = [](const char* option, const std::string& text) {
    const std::optional<double> ns = parse_duration_ns(text);
    if (!ns || std::llround(*ns) <= 0)
      throw std::invalid_argument(fmt::format("{} '{}': want a duration above 0, e.g. 0.3ms, 150us", option, text));
    return static_cast<std::int64_t>(std::llround(*ns));
  };
  settings.deadline_ns = texts.deadline.empty() ? settings.period_ns : duration("--deadline", texts.deadline);
  if (settings.deadline_ns > settings.period_ns)
    throw std::invalid_argument(fmt::format("--deadline {}: above the period ({}); the cycles of one activity never overlap",
                                            texts.deadline, format_duration(settings.period_ns)));
  settings.budget_ns = texts.budget.empty() ? default_budget_ns : duration("--budget", texts.budget);
  if (settings.budget_ns > settings.deadline_ns)
    throw std::invalid_argument(fmt::format("--budget {}: above the deadline ({})", format_duration(settings.budget_ns),
                                            format_duration(settings.deadline_ns)));
  settings.on_miss = parse_miss_action(texts.on_miss).value_or(MissAction::count);  // CLI11 checked it
  settings.watch_contract = texts.watch == "on";
  for (const auto& text : texts.chain_ends) settings.chain_ends.push_back(parse_chain_end(text));
  for (const auto& text : texts.stamp_from) settings.stamp_from.push_back(parse_stamp_from(text));
  if (texts.sched_deadline.empty()) return;
  settings.sched_runtime_ns = duration("--sched-deadline", texts.sched_deadline);
  if (settings.sched_runtime_ns > settings.deadline_ns)
    throw std::invalid_argument(fmt::format("--sched-deadline {}: a runtime above the deadline ({})", texts.sched_deadline,
                                            format_duration(settings.deadline_ns)));
  if (settings.deadline_ns < settings.period_ns)
    throw std::invalid_argument(fmt::format(
        "--sched-deadline with --deadline {}: the reservation is due at the end of the period ({}); Linux throttles "
        "a shorter one off the activity's grid, so a deadline below the period needs --rt-priority",
        format_duration(settings.deadline_ns), format_duration(settings.period_ns)));
  if (settings.budget_ns > settings.sched_runtime_ns)
    throw std::invalid_argument(fmt::format("--sched-deadline {}: below the budget ({}); the reservation must hold a cycle",
                                            texts.sched_deadline, format_duration(settings.budget_ns)));
  if (settings.rt_priority > 0)
    throw std::invalid_argument("--sched-deadline and --rt-priority: give one scheduling class");
  if (settings.cpu >= 0)
    throw std::invalid_argument("--sched-deadline and --cpu: the kernel refuses SCHED_DEADLINE for a thread pinned to one CPU");
}

struct PortTexts {
  std::string delivery;       // --delivery
  std::string shared_memory;  // --shared-memory
};

void add_port_options(CLI::App& app, PortTexts& texts) {
  app.add_option("--delivery", texts.delivery,
                 "who makes an OutPort's remote calls: writer (write() itself when the subscription is idle) "
                 "or thread (always the subscription's delivery thread)")
      ->check(CLI::IsMember({"writer", "thread"}))
      ->default_str("as each port was built (writer)");
  app.add_option("--shared-memory", texts.shared_memory,
                 "whether an OutPort gives InPorts of other processes of this host and user its "
                 "shared-memory ring, read in the reader's cycle with no call per datum (on), or always "
                 "CORBA (off)")
      ->check(CLI::IsMember({"on", "off"}))
      ->default_str("as each port was built (on)");
}

void apply_port_options(const PortTexts& texts, RunSettings& settings) {
  if (!texts.delivery.empty())
    settings.delivery = texts.delivery == "thread" ? OutPortOptions::Delivery::thread
                                                   : OutPortOptions::Delivery::writer_when_idle;
  if (!texts.shared_memory.empty()) settings.shared_memory = texts.shared_memory == "on";
}

// Parses the command line into settings; returns an exit status when the process should stop
// here (--help, or a bad command line: 2).
std::optional<int> parse_command_line(int argc, char** argv, const char* program, const ComponentMain& main,
                                      RunSettings& settings, ParseMode mode) {
  const bool alone = mode == ParseMode::process;
  auto split = split_orb_arguments(argc, argv);
  if (!alone && !split.orb.empty()) {
    std::fprintf(stderr, "%s: %s: -ORB options go to rtm-container, before the first --\n", program, split.orb[0].c_str());
    return 2;
  }
  if (settings.name.empty()) settings.name = (main.kind.empty() ? std::string("component") : main.kind) + "0";
  settings.orb_args = std::move(split.orb);
  std::string naming_text;
  CLI::App app(main.description.empty() ? "RTM component" : main.description, program);
  if (alone) {
    app.add_option("--name", settings.name, "component name, bound as <host>.host_cxt/<name>.rtc")
        ->capture_default_str();
    add_naming_option(app, naming_text);
  }
  ScheduleTexts schedule_texts;
  add_schedule_options(app, schedule_texts);
  app.add_option("--rt-priority", settings.rt_priority, "SCHED_FIFO priority of the activity (1..99)")
      ->check(CLI::Range(0, 99));
  app.add_option("--cpu", settings.cpu,
                 main.pin_process_to_cpu && alone ? "pin the process to this CPU" : "pin the component's threads to this CPU")
      ->check(CLI::NonNegativeNumber);
  ContractTexts contract_texts;
  add_contract_options(app, contract_texts, main.budget_ns, settings);
  app.add_flag("--on", settings.turn_on, "turn the component on once it is up");
  PortTexts port_texts;
  add_port_options(app, port_texts);
  std::string access_text = "owner";
  if (alone) add_process_options(app, settings, access_text);
  app.add_option("--log-cycles", settings.cycle_log,
                 "log what each cycle read and wrote to this MCAP file, for rtm replay (replaced if there)");
  if (main.add_options) main.add_options(app);
  // A wrapper script may add its own default before the user's: the last one given wins.
  for (auto* option : app.get_options()) {
    if (option->get_expected_max() == 1) option->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
  }

  std::vector<const char*> own_argv;
  for (const auto& arg : split.own) own_argv.push_back(arg.c_str());
  try {
    app.parse(static_cast<int>(own_argv.size()), own_argv.data());
    apply_schedule_texts(schedule_texts, settings);
    apply_contract_texts(contract_texts, main.budget_ns, settings);
    settings.access = *parse_access_policy(access_text);
    check_name(settings.name);
    apply_port_options(port_texts, settings);
    if (alone) settings.naming = naming_from(naming_text);
    if (main.validate) main.validate(settings);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // --help: 0; CLI11's own codes (105, 114, ...) are all "bad command line"
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "%s: %s\n", program, e.what());
    return 2;
  }
  return alone ? check_endpoints(program, settings) : std::nullopt;
}

void add_naming_option(CLI::App& app, std::string& text) {
  app.add_option("--naming", text, "naming service host:port")
      ->default_str(NamingAddress::from_environment().to_string())
      ->envname("RTM_NAMING");
}

NamingAddress naming_from(const std::string& text) {
  return text.empty() ? NamingAddress::from_environment() : NamingAddress::parse(text);
}

// The options of the process as a whole: its memory, its endpoints, certificates and access
// screen (rtm-container takes these for all its members).
void add_process_options(CLI::App& app, RunSettings& settings, std::string& access_text) {
  app.add_flag("--mlock", settings.lock_memory, "lock the process's memory (mlockall)");
  app.add_option("--endpoint", settings.endpoints,
                 "omniORB endpoint, repeatable (default: giop:tcp:127.0.0.1: and giop:unix:; with --tls: "
                 "giop:ssl:: on every interface and giop:unix:)");
  app.add_option("--tls", settings.tls_folder,
                 "TLS folder (`rtm tls init`): serve and call giop:ssl: endpoints with its certificates; a peer "
                 "whose certificate the folder's authority issued may change the component")
      ->envname(kTlsFolderVariable);
  app.add_option("--access", access_text,
                 "who may change it (on/off/reset, parameters, connections, puts): owner (this user's "
                 "processes on this host, over giop:unix:, and peers with a certificate of its --tls "
                 "authority) or open (anyone who reaches its endpoints, e.g. a client of the 2004 IDL "
                 "over TCP)")
      ->check(CLI::IsMember({"owner", "open"}))
      ->capture_default_str();
  app.footer("Options -ORB<name> <value> go to omniORB unchanged.");
}

// The default endpoints; an ssl endpoint needs certificates. An exit status when refused.
std::optional<int> check_endpoints(const char* program, RunSettings& settings) {
  if (settings.endpoints.empty()) {
    settings.endpoints = settings.tls_folder.empty() ? std::vector<std::string>{"giop:tcp:127.0.0.1:", "giop:unix:"}
                                                     : std::vector<std::string>{"giop:ssl::", "giop:unix:"};
  }
  for (const auto& endpoint : settings.endpoints) {
    if (endpoint.starts_with("giop:ssl:") && settings.tls_folder.empty()) {
      std::fprintf(stderr, "%s: endpoint %s needs certificates: --tls FOLDER (`rtm tls init` makes one)\n", program,
                   endpoint.c_str());
      return 2;
    }
  }
  return std::nullopt;
}

// A port of the component by name or as <index_prefix><k> (in0, out1); std::invalid_argument
// listing them if none.
template <class Port>
Port& find_port(const std::vector<Port*>& ports, const char* index_prefix, const char* kind, const Component& component,
                const std::string& which, const std::string& option) {
  std::string names;
  for (std::size_t i = 0; i < ports.size(); ++i) {
    if (ports[i]->port_name() == which || index_prefix + std::to_string(i) == which) return *ports[i];
    names += (names.empty() ? "" : ", ") + ports[i]->port_name();
  }
  throw std::invalid_argument(option + ": " + component.name() + " has no " + kind + " " + which + " (" +
                              (names.empty() ? std::string("it has none") : "it has " + names) + ")");
}

InPortBase& find_in_port(Component& component, const std::string& which, const std::string& option) {
  return find_port(component.in_ports(), "in", "InPort", component, which, option);
}

OutPortBase& find_out_port(Component& component, const std::string& which, const std::string& option) {
  return find_port(component.out_ports(), "out", "OutPort", component, which, option);
}

// Whose port `which` is: the component's own, or for MEMBER.PORT a composite's member's; and
// the port's name there.
std::pair<ComponentServant*, std::string> port_owner(const ComponentMain& main, ComponentServant& servant,
                                                     const std::string& which, const std::string& option) {
  const std::size_t dot = which.find('.');
  if (dot == std::string::npos) return {&servant, which};
  const std::string member = which.substr(0, dot);
  const std::vector<ComponentServant*> members = main.members ? main.members() : std::vector<ComponentServant*>{};
  for (ComponentServant* m : members)
    if (m->component().name() == member) return {m, which.substr(dot + 1)};
  throw std::invalid_argument(option + ": " + servant.component().name() +
                              (members.empty() ? " has no members in this process: no member " : " has no member ") + member);
}

// --watch-chain and --stamp-from, on the component or its members. Before on().
void declare_chains(const ComponentMain& main, const RunSettings& settings, ComponentServant& servant) {
  for (const auto& from : settings.stamp_from) {
    const std::string option = "--stamp-from " + from.out;
    auto [owner, name] = port_owner(main, servant, from.out, option);
    OutPortBase& out = find_out_port(owner->component(), name, option);
    std::vector<const InPortBase*> ins;
    for (const auto& in : from.ins) ins.push_back(&find_in_port(owner->component(), in, option));
    out.derive_stamp_from(ins);
    log().info("{}: {} carries the stamp of {}", owner->component().name(), out.port_name(), out.stamp_sources_text());
  }
  for (const auto& end : settings.chain_ends) {
    const std::string option = "--watch-chain " + end.name;
    auto [owner, name] = port_owner(main, servant, end.port, option);
    InPortBase& port = find_in_port(owner->component(), name, option);
    owner->watch_chain({end.name, &port, end.deadline_ns, end.max_age_ns, end.on_miss});
  }
}

// Builds the component and its servant, activates it and binds its names; turns it on when
// asked. Throws what the component's factory or the ORB throws; what was made by then is in
// servant and bindings, for the caller's ordered shutdown.
void bring_up(const ComponentMain& main, const RunContext& context, PortableServer::Servant_var<ComponentServant>& servant,
              std::vector<std::unique_ptr<NameBinding>>& bindings, std::unique_ptr<CycleLog>& cycle_log) {
  const RunSettings& settings = context.settings;
  auto component = main.create_with_orb ? main.create_with_orb(context) : main.create(settings);
  if (!component) throw std::runtime_error("the factory made no component");
  if (component->description().empty()) component->set_description(main.description);
  for (OutPortBase* port : component->out_ports()) {
    if (settings.delivery) port->set_delivery(*settings.delivery);
    if (settings.shared_memory) port->set_shared_memory(*settings.shared_memory);
  }
  component->add_out_port_statistics();
  component->add_process_statistic();
  ActivitySpec activity =
      main.activity ? main.activity(settings, *component) : ActivitySpec{settings.periodic_options()};
  // The log's events come from one thread at a time: the component's own activity, or the
  // thread that turns it on or off while that activity is stopped. Another's tick is neither.
  if (!settings.cycle_log.empty() && std::holds_alternative<ExternalTick>(activity))
    throw std::invalid_argument("--log-cycles: " + settings.name +
                                " runs on another component's tick (a composite's member); log a component that runs its own loop");
  servant = new ComponentServant(std::move(component), std::move(activity));
  servant->keep_holds(std::make_unique<Leases>([s = servant.in()](const std::string& holder, std::uint32_t lease_ms) {
    log().warn("{}: {} stopped renewing its hold ({} ms lease): turning off", s->component().name(), holder, lease_ms);
    try {
      s->off();
    } catch (const std::exception& e) {
      log().warn("{}: off() after the hold ended failed: {}", s->component().name(), e.what());
    } catch (const CORBA::Exception& e) {
      log().warn("{}: off() after the hold ended raised {}", s->component().name(), e._name());
    }
  }));
  if (!settings.await_port.empty())  // refused there for a cycle that is not periodic
    servant->await_before_cycle(find_in_port(servant->component(), settings.await_port, "--await"),
                                settings.await_bound_ns);
  if (settings.watch_contract && main.has_contract) servant->watch_contract(settings.contract());
  declare_chains(main, settings, *servant);
  if (!settings.cycle_log.empty()) cycle_log = std::make_unique<CycleLog>(*servant, settings.cycle_log);
  RTM::RtComponentEx_var reference = servant->activate(context.orb);
  std::vector<ExtraName> extra_names;
  if (main.on_activated) extra_names = main.on_activated(*servant, context);
  bindings.push_back(std::make_unique<NameBinding>(context.orb.orb(), settings.naming,
                                                   ComponentPath::on_this_host(settings.name), reference));
  for (const auto& extra : extra_names) {
    bindings.push_back(std::make_unique<NameBinding>(context.orb.orb(), settings.naming,
                                                     ComponentPath::on_this_host(extra.name), extra.reference));
  }
  if (settings.turn_on) servant->on();
}

// Turns the component off, unbinds its names and deactivates its servant: the ordered
// shutdown, whatever bring_up() made.
void shut_down(PortableServer::Servant_var<ComponentServant>& servant, std::vector<std::unique_ptr<NameBinding>>& bindings,
               std::unique_ptr<CycleLog>& cycle_log, const std::string& name) {
  try {
    if (servant) servant->off();
  } catch (const CORBA::Exception& e) {
    log().warn("{}: off() raised {}", name, e._name());
  } catch (const std::exception& e) {
    log().warn("{}: off() failed: {}", name, e.what());
  }
  cycle_log.reset();  // no more cycles: the log's end is written
  bindings.clear();
  if (servant) servant->deactivate();
}

namespace {

bool warns(const ComponentServant& servant) {
  const TimingContract* contract = servant.timing_contract();
  if (contract != nullptr && contract->on_miss == MissAction::warn) return true;
  const auto chains = servant.chain_status();
  return std::any_of(chains.begin(), chains.end(), [](const auto& c) { return c.on_miss == MissAction::warn; });
}

}  // namespace

ContractWarner::ContractWarner(std::vector<const ComponentServant*> servants) {
  for (const ComponentServant* servant : servants)
    if (servant != nullptr && warns(*servant)) servants_.push_back(servant);
  if (servants_.empty()) return;
  for (const ComponentServant* servant : servants_) {
    seen_.push_back(servant->contract_stats());
    seen_chains_.push_back(servant->chain_status());
  }
  thread_ = std::thread([this] { loop(); });
}

std::vector<const ComponentServant*> ContractWarner::watched(const ComponentMain& main, const ComponentServant* servant) {
  std::vector<const ComponentServant*> out{servant};
  if (servant != nullptr && main.members)
    for (const ComponentServant* m : main.members()) out.push_back(m);
  return out;
}

ContractWarner::~ContractWarner() {
  {
    std::lock_guard lock(mu_);
    stop_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void ContractWarner::loop() {
  set_thread_name("rtm-contract");
  std::unique_lock lock(mu_);
  while (!cv_.wait_for(lock, std::chrono::seconds(1), [this] { return stop_; })) {
    for (std::size_t i = 0; i < servants_.size(); ++i) {
      const CycleWatchStats now = servants_[i]->contract_stats();
      CycleWatchStats& before = seen_[i];
      const std::uint64_t over = now.over_budget - before.over_budget;
      const std::uint64_t missed = now.missed_deadline - before.missed_deadline;
      const TimingContract* contract = servants_[i]->timing_contract();
      if (contract != nullptr && contract->on_miss == MissAction::warn && (over > 0 || missed > 0)) {
        const TimingContract& c = *contract;
        log().warn("{}: contract missed in {} of {} cycles: {} past the deadline of {} (worst response {}), {} over the "
                   "budget of {} (longest cycle {})",
                   c.component, std::max(over, missed), now.cycles - before.cycles, missed,
                   format_duration(c.effective_deadline_ns()), format_duration(now.response_max_ns), over,
                   c.budget_ns > 0 ? format_duration(c.budget_ns) : std::string("none"), format_duration(now.cycle_max_ns));
      }
      before = now;
      warn_chains(i);
    }
  }
}

void ContractWarner::warn_chains(std::size_t i) {
  auto now = servants_[i]->chain_status();
  auto& before = seen_chains_[i];
  for (std::size_t k = 0; k < now.size() && k < before.size(); ++k) {
    const auto& c = now[k];
    const std::uint64_t late = c.late - before[k].late, stale = c.stale - before[k].stale;
    if (c.on_miss == MissAction::warn && (late > 0 || stale > 0))
      log().warn("{}: chain {} missed: {} data past its deadline (latency max {}), {} cycles on data past its max "
                 "age (age max {})",
                 servants_[i]->component().name(), c.name, late, format_duration(c.latency_max_ns), stale,
                 format_duration(c.age_max_ns));
  }
  before = std::move(now);
}

// The access screen, the certificates and the ORB of the process; nullopt (and one error line)
// when one of them cannot be had.
bool start_orb(const char* program, const RunSettings& settings, std::optional<Orb>& orb) {
  configure_access(settings.access);
  if (!settings.tls_folder.empty()) {
    try {
      configure_tls(check_tls_folder(settings.tls_folder));
    } catch (const std::exception& e) {
      std::fprintf(stderr, "%s: --tls: %s\n", program, e.what());
      return false;
    }
  }
  std::vector<std::string> orb_args;
  for (const auto& endpoint : settings.endpoints) orb_args.insert(orb_args.end(), {"-ORBendPoint", endpoint});
  orb_args.insert(orb_args.end(), settings.orb_args.begin(), settings.orb_args.end());
  try {
    orb.emplace(orb_args);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: %s\n", program, e.what());
    return false;
  }
  return true;
}

}  // namespace detail

int run_component(int argc, char** argv, const ComponentMain& main) {
  using namespace detail;
  const char* program = program_name(argc > 0 ? argv[0] : "rtm-component");
  if (!main.create && !main.create_with_orb) {
    std::fprintf(stderr, "%s: no component factory given\n", program);
    return 1;
  }
  TerminationSignals signals;

  RunSettings settings;
  if (auto exit_status = parse_command_line(argc, argv, program, main, settings, ParseMode::process)) return *exit_status;
  if (settings.print_contract && !main.has_contract) {
    std::printf("{\"component\":\"%s\",\"contract\":null}\n", settings.name.c_str());
    return 0;
  }
  if (settings.print_contract) {
    // Started under chrt, the activity would take the priority it inherits: so does its contract.
    if (settings.rt_priority == 0 && settings.sched_runtime_ns == 0) {
      int policy = SCHED_OTHER;
      sched_param param{};
      if (pthread_getschedparam(pthread_self(), &policy, &param) == 0 && (policy == SCHED_FIFO || policy == SCHED_RR))
        settings.rt_priority = param.sched_priority;
    }
    std::printf("%s\n", contract_json(settings.contract()).c_str());
    return 0;
  }
  if (settings.cpu >= 0 && main.pin_process_to_cpu) pin_process_to_cpu(settings.cpu);
  const int inherited = keep_real_time_for_the_activity(settings.name);
  if (settings.rt_priority == 0) settings.rt_priority = inherited;
  // Threads on the real-time path that are not the activity (a CAN listener's receive thread,
  // a delivery thread, an ORB thread serving an admitted put) take its priority.
  set_path_thread_priority(settings.rt_priority);

  // ---- bring up: access policy, certificates, ORB, component, servant, names ----
  std::optional<Orb> orb;
  if (!start_orb(program, settings, orb)) return 1;

  int status = 0;
  {
    PortableServer::Servant_var<ComponentServant> servant;
    std::vector<std::unique_ptr<NameBinding>> bindings;
    std::unique_ptr<CycleLog> cycle_log;
    try {
      bring_up(main, RunContext{settings, *orb}, servant, bindings, cycle_log);
    } catch (const CORBA::Exception& e) {
      log().error("{} could not start: CORBA {}", settings.name, e._name());
      status = 1;
    } catch (const std::exception& e) {
      log().error("{} could not start: {}", settings.name, e.what());
      status = 1;
    }

    if (status == 0) {
      const ContractWarner warner(ContractWarner::watched(main, servant.in()));
      const int received = signals.wait();
      log().info("stopping {} ({})", settings.name, received == SIGINT ? "SIGINT" : "SIGTERM");
    }

    // ---- shut down in order: no more cycles, no more names, no more servants ----
    shut_down(servant, bindings, cycle_log, settings.name);
  }
  orb.reset();
  return status;
}

}  // namespace rtm
