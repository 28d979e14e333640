// SPDX-License-Identifier: Apache-2.0
// A composite as a value: its members, the order a shared tick runs them in and their phases,
// and the connections between their ports, by name, each with its policy. A system file
// (`rtm up`), the remote servo and the shared-tick servo each make one and check it once,
// before anything is wired; every problem is reported at once, each a sentence that names
// both ends:
//
//   rtm::Diagram d{.name = "servo",
//                  .members = {{"sensor0"}, {"controller0"}, {"actuator0"}},
//                  .ticked = true,
//                  .connections = {{{"sensor0", "wrench"}, {"controller0", "wrench"}},
//                                  {{"controller0", "twist"}, {"actuator0", "twist"}}}};
//   d.check(rtm::catalogue_of({&sensor, &controller, &actuator}));
//
// What is checked: members named once; each connection between listed members, from an
// OutPort to an InPort that exist, of the same type, with the same unit for each element when
// both ends say theirs; one writer per InPort; a connection listed once; and, in a ticked
// diagram (one thread runs the members in the listed order each cycle), every connection
// downstream in that order unless it is declared feedback (read one cycle later): a loop is
// never left to the order the members happen to run in. Phases lie within the period.
#pragma once

#include "rtm/conn_policy.h"

#include <cstdint>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace rtm {

class Component;
class InPortBase;
class OutPortBase;

// "<member>.<port>", split at the last '.' (a member may be "host/name"; a port may be "in0").
struct PortRef {
  std::string member;
  std::string port;
  // Throws std::invalid_argument naming the text when it has no '.' or an empty side.
  static PortRef parse(std::string_view text);
  std::string to_string() const { return member + "." + port; }
  bool operator==(const PortRef&) const = default;
};

// What the check needs to know of a port.
struct PortShape {
  bool is_in = false;
  std::string type;                // "RTM::TimedFloat6"
  std::vector<std::string> units;  // one per element; empty when the port does not say them
};

// Where the check finds the members' ports: find() gives the InPort (in) or OutPort (!in) a
// PortRef names, or nullopt when the member has none of that name; names() the ports a member
// has in one direction, for the message (may be unset).
struct PortCatalogue {
  std::function<std::optional<PortShape>(const PortRef&, bool in)> find;
  std::function<std::vector<std::string>(const std::string& member, bool in)> names;
};

// The ports of components of this process, by name (and "in<N>"/"out<N>").
PortCatalogue catalogue_of(const std::vector<const Component*>& members);
// The InPort / OutPort of a component of this process that a PortRef's port names (its name,
// or "in<N>"/"out<N>"), as catalogue_of() finds it; nullptr when it has none.
InPortBase* in_port_of(const Component& component, std::string_view port);
OutPortBase* out_port_of(const Component& component, std::string_view port);

// A diagram that does not hold: every problem, one per line, in what().
class DiagramError : public std::invalid_argument {
 public:
  DiagramError(const std::string& diagram, std::vector<std::string> problems);
  const std::vector<std::string>& problems() const { return problems_; }

 private:
  std::vector<std::string> problems_;
};

struct Diagram {
  struct Member {
    std::string name = {};
    std::int64_t phase_ns = 0;  // its cycles at k * period + phase_ns
  };
  struct Connection {
    PortRef from;  // an OutPort
    PortRef to;    // an InPort
    ConnPolicy policy = ConnPolicy::repeated();
    bool feedback = false;  // in a ticked diagram: read in the next cycle, against the order
    std::string text() const { return from.to_string() + " -> " + to.to_string(); }
  };

  std::string name = {};
  std::vector<Member> members = {};
  // One thread runs the members in the order listed, each cycle (a shared tick); false: each
  // member runs on its own activity, and the order says nothing.
  bool ticked = false;
  std::int64_t period_ns = 0;  // 0: not said (phases are then not checked against it)
  std::vector<Connection> connections = {};

  // Every problem of the diagram's own structure (members, order, writers, phases), then, with
  // ports, every problem of its connections' ends. Empty when it holds.
  std::vector<std::string> problems(const PortCatalogue* ports = nullptr) const;
  // Throws DiagramError listing problems(&ports).
  void check(const PortCatalogue& ports) const;
  // Throws DiagramError listing problems() (no port looked at).
  void check_structure() const;
  // For a composite handed its members: where each member is in `given` (their names), in the
  // diagram's order. Throws std::invalid_argument "<owner>: diagram member <m> was not given"
  // or "<owner>: member <m> is not in the diagram".
  std::vector<std::size_t> arrange(const std::vector<std::string>& given, std::string_view owner) const;
};

}  // namespace rtm
