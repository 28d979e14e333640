// SPDX-License-Identifier: Apache-2.0
// The component runner: the main() every component executable shares.
//
//   int main(int argc, char** argv) {
//     double gain = 1.0;
//     return rtm::run_component(argc, argv, {
//         .kind = "controller",
//         .description = "proportional force controller",
//         .add_options = [&](CLI::App& app) { app.add_option("--gain", gain, "P gain"); },
//         .create = [&](const rtm::RunSettings& s) { return std::make_unique<Controller>(s.name, gain); },
//     });
//   }
//
// Command line (besides the component's own options):
//   --name NAME          component name (default <kind>0), bound as <host>.host_cxt/NAME.rtc
//   --naming HOST:PORT   naming service (default $RTM_NAMING, else 127.0.0.1:2809)
//   --period 2ms         cycle period, 50us to 1h: 2ms, 500us, 250000ns, 0.002 or 0.002s
//   --phase 0.5ms        cycles at k * period + phase on CLOCK_MONOTONIC: one grid for every
//                        component of the host with that period (default: from the first on())
//   --rt-priority N      SCHED_FIFO priority of the activity thread (1..99)
//   --deadline D         each cycle ends within D of its release (default: the period)
//   --budget B           the longest one cycle may run (default: ComponentMain::budget_ns)
//   --on-miss count|warn|brake
//                        what a cycle past its budget or deadline does besides being counted
//   --sched-deadline R   SCHED_DEADLINE: R reserved every period, due at its end
//   --print-contract     print the timing contract as JSON and exit (`rtm check` reads it)
//   --watch-chain NAME:PORT[:DEADLINE[:MAX_AGE[:ON_MISS]]]
//                        the end of a chain: how old PORT's data are at each cycle's end
//   --stamp-from OUT=IN[+IN...]
//                        OutPort OUT's data carry the stamp of what InPort IN gave (the
//                        oldest of several): a chain passes through without the component
//                        copying tm. A composite's member's ports are MEMBER.PORT.
//   --cpu N              pin the process (and so its activity) to CPU N
//   --mlock              lock the process's memory
//   --endpoint EP        omniORB endpoint, repeatable (default giop:tcp:127.0.0.1: and a
//                        giop:unix: socket, which local omniORB clients prefer)
//   --on                 turn the component on once it is up
//   --delivery writer|thread
//                        who makes an OutPort's remote calls: write() itself when the
//                        subscription is idle (writer, the default) or always the
//                        subscription's delivery thread (thread); see OutPortOptions
//   --shared-memory on|off
//                        whether an OutPort gives InPorts of other processes of this host
//                        and user its shared-memory ring (on, the default) or always CORBA
//   -ORB<option> VALUE   passed to omniORB unchanged
//
// Every OutPort of the component reports, as statistics of the component (`rtm cat`), how
// long write() held the activity (<port>.write_p50 / _p99 / _max, us), how many data
// write() delivered itself (<port>.by_writer) and how many calls outlived their bound
// (<port>.timed_out).
//
// The runner binds the name (and keeps it bound across naming-service restarts), logs
// "bound NAME at HOST.host_cxt/NAME.rtc via ADDRESS", then waits for SIGINT/SIGTERM (taken
// synchronously by sigwait, never in a handler) and shuts down in order: activity off, name
// unbound, servants deactivated, ORB destroyed. An unreachable naming service is one error
// line; the component keeps running and binds when the service appears.
#pragma once

#include "host/access.h"
#include "rtm/component.h"
#include "rtm/naming.h"
#include "rtm/parameters.h"

#include <CLI/App.hpp>
#include <CLI/Validators.hpp>

#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

namespace rtm {

// What the command line asked for.
struct RunSettings {
  std::string name;
  NamingAddress naming;
  std::int64_t period_ns = 2'000'000;
  // --phase: cycles at k * period_ns + phase_ns on CLOCK_MONOTONIC; unset: from the first on().
  std::optional<std::int64_t> phase_ns;
  // --await PORT[:BOUND]: each cycle first waits for a new datum on that InPort, at most BOUND
  // after it was due (ComponentServant::await_before_cycle). Empty: it does not wait.
  std::string await_port;
  std::int64_t await_bound_ns = 0;
  int rt_priority = 0;   // 0: SCHED_OTHER
  int cpu = -1;          // -1: no affinity
  bool lock_memory = false;
  bool turn_on = false;
  // --delivery: applied to every OutPort of the component once it is built; unset: each
  // port keeps what it was built with.
  std::optional<OutPortOptions::Delivery> delivery;
  // --shared-memory: likewise for OutPortOptions::shared_memory.
  std::optional<bool> shared_memory;
  std::vector<std::string> endpoints;  // omniORB endpoints, e.g. giop:tcp:127.0.0.1:
  AccessPolicy access = AccessPolicy::owner;  // --access: who may change it (host/access.h)
  std::string tls_folder;  // --tls / $RTM_TLS: certificates for giop:ssl: endpoints (host/tls.h)
  std::vector<std::string> orb_args;   // -ORB... options, passed through
  // --log-cycles FILE: every read and write of every cycle, into an MCAP file a replay steps
  // the component through again (host/cycle_log.h). Empty: none.
  std::string cycle_log;
  // The timing contract beside the schedule above (rt/contract.h, docs/timing.md):
  std::int64_t deadline_ns = 0;       // --deadline: each cycle ends within it of its release; 0: the period
  std::int64_t budget_ns = 0;         // --budget: the longest one cycle runs; default ComponentMain::budget_ns
  MissAction on_miss = MissAction::count;  // --on-miss
  std::int64_t sched_runtime_ns = 0;  // --sched-deadline RUNTIME: SCHED_DEADLINE instead of --rt-priority
  bool watch_contract = true;         // --watch-contract off: cycles are not watched against it
  // --watch-chain NAME:PORT[:DEADLINE[:MAX_AGE[:ON_MISS]]]: this component ends a chain entering by PORT
  // (ComponentServant::watch_chain); rtm up gives it from a system file's chains.
  struct ChainEnd {
    std::string name, port;
    std::int64_t deadline_ns = 0, max_age_ns = 0;
    MissAction on_miss = MissAction::count;
  };
  std::vector<ChainEnd> chain_ends;
  // --stamp-from OUT=IN[+IN...]: OutPort OUT's data derive their stamp from these InPorts
  // (OutPortBase::derive_stamp_from); rtm up gives it for each component inside a chain.
  struct StampFrom {
    std::string out;
    std::vector<std::string> ins;
  };
  std::vector<StampFrom> stamp_from;
  bool print_contract = false;        // --print-contract: print it as JSON and exit (`rtm check`)

  // The contract these settings describe, for the component called name.
  TimingContract contract() const;

  // The periodic activity these settings describe (thread named after the component).
  PeriodicOptions periodic_options() const;
};

// What a component's main has at hand once the ORB is up.
struct RunContext {
  const RunSettings& settings;
  Orb& orb;
};

// A further name bound beside the component's own while it runs (a composite's members).
struct ExtraName {
  std::string name;  // bound as <host>.host_cxt/<name>.rtc
  CORBA::Object_var reference;
};

// How to make one kind of component.
struct ComponentMain {
  std::string kind = {};    // "sensor", "controller", ...: default name <kind>0
  std::string description = {};  // one line for --help
  // Adds the component's own options to app (bound to variables the caller owns). Optional.
  std::function<void(CLI::App& app)> add_options = {};
  // Checks the parsed command line as a whole: parameter ranges, options that apply only
  // together. std::invalid_argument or CLI::ValidationError: one error line, exit status 2.
  std::function<void(const RunSettings&)> validate = {};
  // Builds the component after the command line is parsed. An exception becomes one error
  // line and exit status 1.
  std::function<std::unique_ptr<Component>(const RunSettings&)> create = {};
  // Instead of create, for a component that needs the ORB to be built: a composite that
  // activates its members, or finds them through the naming service.
  std::function<std::unique_ptr<Component>(const RunContext&)> create_with_orb = {};
  // The activity that runs it; default: periodic with the settings' period, priority, CPU.
  std::function<ActivitySpec(const RunSettings&, Component&)> activity = {};
  // After the servant is activated, before its name is bound: e.g. a composite hands out a
  // member's port (ComponentServant::expose_in_port). Returns names to bind beside its own.
  std::function<std::vector<ExtraName>(ComponentServant&, const RunContext&)> on_activated = {};
  // A composite's members made in this process (after create_with_orb): their ports are named
  // MEMBER.PORT by --watch-chain and --stamp-from, and the host warns of their misses too.
  std::function<std::vector<ComponentServant*>()> members = {};
  // The longest one of its cycles takes, start to end, on the machines it was measured on: the
  // budget of its timing contract unless --budget says otherwise (docs/timing.md). 0: none declared.
  std::int64_t budget_ns = 0;
  // false for a component that runs no periodic loop of its own (a composite whose members run
  // theirs, or its tick): it has no contract, and --print-contract says so.
  bool has_contract = true;
  // --cpu pins the whole process before any thread starts (true), or is left to the component,
  // which pins the threads it runs from RunSettings::cpu (false).
  bool pin_process_to_cpu = true;
};

// Runs one component until SIGINT/SIGTERM. Returns the process exit status: 0 after a clean
// shutdown, 1 when the component could not start, 2 for a bad command line.
int run_component(int argc, char** argv, const ComponentMain& main);

// Adds an option that takes exactly N numbers into values (six gains, six limits), with the
// current values shown as its default in --help.
template <typename T, std::size_t N>
CLI::Option* add_array_option(CLI::App& app, const std::string& name, std::array<T, N>& values,
                              const std::string& description) {
  std::ostringstream shown;
  for (std::size_t i = 0; i < N; ++i) shown << (i == 0 ? "" : " ") << values[i];
  return app
      .add_option_function<std::vector<T>>(
          name, [&values](const std::vector<T>& given) { std::copy_n(given.begin(), N, values.begin()); },
          description)
      ->expected(static_cast<int>(N))
      ->default_str(shown.str());
}

// One option for each parameter of table (rtm/parameters.h), bound to its field of params:
// --name with '-' for '_', "description [unit]" as its help, the field's value as its default,
// a count refused out of its bounds by the parser. Call table.validate(params) after parsing
// (run_component's validate) for the bounds of the numbers.
template <class P>
void add_parameter_options(CLI::App& app, const ParameterTable<P>& table, P& params) {
  for (const auto& decl : table.entries()) {
    std::string option = "--" + decl.name;
    std::replace(option.begin(), option.end(), '_', '-');
    const std::string help = decl.unit.empty() ? decl.description : decl.description + " [" + decl.unit + "]";
    decl.visit(params, [&](auto& param) {
      auto& field = param.value();
      using T = std::remove_cvref_t<decltype(field)>;
      if constexpr (std::is_integral_v<T>) {
        app.add_option(option, field, help)
            ->check(CLI::Range(static_cast<T>(std::max(decl.bounds.min, 0.0)),
                               static_cast<T>(std::min(decl.bounds.max, double(std::numeric_limits<T>::max())))))
            ->capture_default_str();
      } else if constexpr (std::is_same_v<T, float>) {
        app.add_option(option, field, help)->capture_default_str();
      } else {
        add_array_option(app, option, field, help);
      }
    });
  }
}

// Parses a period: "2ms", "500us", "250000ns", "0.002s" or "0.002" (seconds). Throws
// std::invalid_argument naming the text when it is not a positive duration.
std::int64_t parse_period_ns(std::string_view text);
// "0.5ms" and the like, from 0 to less than period_ns; std::invalid_argument saying what is wanted.
std::int64_t parse_phase_ns(std::string_view text, std::int64_t period_ns);
// "--await PORT[:BOUND]": the port's name and the bound (above 0, below the period; a tenth
// of the period when left out). Throws std::invalid_argument naming what is wrong.
std::pair<std::string, std::int64_t> parse_await(std::string_view text, std::int64_t period_ns);

// A contract as one line of JSON: what `--print-contract` prints and `rtm check` reads.
std::string contract_json(const TimingContract& contract);

// Splits -ORB<option> <value> pairs (omniORB's syntax) out of argv. The rest, argv[0] first,
// stays in order for the command-line parser.
struct SplitArguments {
  std::vector<std::string> own;
  std::vector<std::string> orb;
};
SplitArguments split_orb_arguments(int argc, const char* const* argv);

}  // namespace rtm
