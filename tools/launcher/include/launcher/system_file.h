// SPDX-License-Identifier: Apache-2.0
// A system file: the components to launch, the connections to make and the components to turn
// on, as `rtm up` reads it (YAML):
//
//   name: force-servo              # optional; default: the file name without extension
//   naming: 127.0.0.1:2809         # optional; --naming / RTM_NAMING override it
//   components:
//     - name: sensor0
//       command: [rtm-sensor, --bus, "local:/tmp/pa10.bus"]   # program + arguments
//     - name: controller0
//       command: rtm-controller
//       host: servo_host             # optional: components of one host run in one process
//       parameters:                  # optional: set (`rtm set`) once it is bound, before any
//         gain: [0.0004, 0.0004, 0.0004, 0, 0, 0]  # connection and before it is turned on;
//         stale_periods: 3           # a number, a list of numbers, or their text
//       parameter_sets:              # optional: `rtm up FILE --set soft` sets these over them
//         soft: {gain: [0.0002, 0.0002, 0.0002, 0, 0, 0]}
//       contract: {phase: 0.1ms, deadline: 0.5ms, budget: 80us, cpu: 1, priority: 80, on_miss: warn}
//                                    # optional: its timing contract (docs/timing.md), given to the
//                                    # program as options after its command's own: --phase ...
//   chains:                          # optional: end-to-end contracts (docs/timing.md)
//     - {name: wrist_to_twist, path: [sensor0.wrench, controller0, actuator0], deadline: 1ms, max_age: 2ms}
//   connections:
//     - {from: sensor0.out0, to: controller0.in0}              # type: repeated (default)|once
//     - {from: joystick0.out0, to: controller0.in1, policy: "reader=latest depth=4"}
//                                    # a whole connection policy (rtm/conn_policy.h's text)
//   activate: [sensor0]
//
// A program without a '/' is searched in $RTM_BIN_PATH (':'-separated), then $PATH; one with
// a '/' is taken relative to the file's folder. `rtm up` adds `--name <name> --naming <addr>`.
// Components with the same 'host' (a name of its own, no component's) run in one process:
//   rtm-container --name <host> --naming <addr> -- <member> <program> [args...] -- <member> ...
// so no word of their commands may be '--'.
// docs/system-files.md describes the format and what `rtm up` does with it, step by step.
#pragma once

#include "rtm/conn_policy.h"
#include "rtm/diagram.h"
#include "rt/contract.h"

#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace rtm::cli {

// A malformed system file: the message names the file and, where known, the line.
class SystemFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct SystemFile {
  struct Component {
    std::string name;
    std::vector<std::string> command;  // program, then arguments
    // In the file's order: the name and the value as `rtm set` takes it ("0.0004 0.0004 ...").
    using Parameters = std::vector<std::pair<std::string, std::string>>;
    Parameters parameters;
    // Named sets (OpenRTM's configuration sets), in the file's order: a set's values replace
    // or join `parameters` when `rtm up --set NAME` chooses it.
    std::vector<std::pair<std::string, Parameters>> parameter_sets;
    // The process it runs in with the other components of that host (rtm-container); "" for a
    // process of its own.
    std::string host{};
    // Its timing contract as written, in the file's order: a key ("period", "phase",
    // "deadline", "budget", "await", "cpu", "priority", "sched_deadline", "on_miss") and its text.
    std::vector<std::pair<std::string, std::string>> contract{};

    // parameters, with the set's values over them ("" or a set it lacks: parameters alone).
    Parameters parameters_with(const std::string& set) const;
    // The command, then the contract as the runner's options (--phase 0.1ms ...): given last,
    // they win over the same options in the command.
    std::vector<std::string> arguments() const;
  };
  struct Connection {
    std::string from, to;  // "<component>.<port>"
    ConnPolicy policy;     // 'type' sets its once/repeated; 'policy' the rest (or all of it)
  };

  std::filesystem::path path;      // absolute
  std::string name;
  std::optional<std::string> naming;
  std::vector<Component> components;
  std::vector<Connection> connections;
  std::vector<std::string> activate;
  std::vector<rtm::ChainContract> chains;  // 'chains': each path names components the file lists

  // Throws SystemFileError for an unreadable file, bad YAML, a missing or mistyped key, a
  // duplicate component, a host named like a component, a '--' in a hosted component's command,
  // a connection/activation naming a component the file does not list, or wiring that does not
  // hold (diagram()).
  static SystemFile load(const std::filesystem::path& file);
  static SystemFile parse(const std::string& yaml_text, const std::filesystem::path& path);

  // What rtm up runs a component with: its arguments(), then --stamp-from for each chain that
  // passes through it (stamp_derivations()), then --watch-chain for each chain that ends at it
  // by a named InPort ("actuator0.twist"), which measures the chain while it runs.
  std::vector<std::string> arguments(const Component& component) const;
  // For each chain that passes through component (neither its head nor its end) along the
  // file's connections: the OutPort it leaves by and the InPorts it enters by. The component's
  // data on that OutPort then carry the stamp of what came in (--stamp-from OUT=IN[+IN]), so
  // the chain's age is kept through it whether or not it copies the stamp itself. A hop the
  // file's connections do not show (a composite wires it) gives none.
  std::vector<std::pair<std::string, std::vector<std::string>>> stamp_derivations(const Component& component) const;

  // The names of the parameter sets its components declare, sorted, each once.
  std::vector<std::string> parameter_set_names() const;

  // The file as YAML that parse() reads back to the same content (rtm serve's "save").
  std::string to_yaml() const;
  // Its components and connections as a diagram (not ticked: each component runs on its own
  // activity). parse() refuses a file whose diagram does not hold by its structure alone (an
  // InPort with two writers, a connection listed twice); `rtm up` checks the rest against the
  // running components' ports before it connects anything.
  rtm::Diagram diagram() const;
};

// The program to execute for `program` as written in a system file in folder `base`.
// Throws SystemFileError when it is not found or not executable.
std::filesystem::path find_program(const std::string& program, const std::filesystem::path& base);

}  // namespace rtm::cli
