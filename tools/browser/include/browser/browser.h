// SPDX-License-Identifier: Apache-2.0
// The component browser: what `rtm` asks of the naming service and of components, as plain
// results the command line prints as text or JSON. No printing here.
#pragma once

#include "rtm/conn_policy.h"
#include "rtm/naming.h"

#include <RTM.hh>
#include <RTMExt.hh>

#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace rtm::cli {

// A failure the user can act on: unknown component or port, type mismatch, refused subscribe.
class BrowseError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class Direction { in, out };

// "<component>.<port>": component is "name" or "host/name"; port is the port's name, or
// "in<N>"/"out<N>" for the N-th InPort/OutPort. Split at the last '.'.
struct PortAddress {
  std::string component;
  std::string port;
  static PortAddress parse(std::string_view text);  // throws std::invalid_argument
  std::string to_string() const { return component + "." + port; }
};

// One element of a port's datum, as the port describes it (RTMExt PortDescription).
struct ElementInfo {
  std::string name;  // "fx"
  std::string unit;  // "N", "" when dimensionless
};

struct PortInfo {
  Direction direction = Direction::in;
  int index = 0;             // position in in_ports()/out_ports()
  std::string name;
  std::string type;          // "RTM::TimedFloat6"
  bool extended = false;     // has the RTMExt counters
  std::string description;   // what the port carries; "" when it does not say
  std::vector<ElementInfo> elements;  // per value of a datum; empty when not described
  RTM::PortCounters counters{};
  std::string last_error;
  struct Subscription {
    std::string peer;        // "<component>.<port>", or "?" when the InPort does not tell
    std::string req_type;    // "once" / "repeated"
    bool in_process = false;
    std::string path;        // "in-process", "shared memory" or "CORBA"
    std::string kind;        // rtm::ConnKind's text ("CORBA by writer"); "" from an older build
    std::string policy;      // the connection policy (rtm/conn_policy.h), defaults filled in; ""
                             // from an older build
    std::optional<ConnPolicy> asked;  // as the subscriber asked it (what a system file keeps)
    std::string reader;      // what the InPort keeps ("latest", "fifo:8"), "" when untold
    unsigned long long pushed = 0, dropped = 0;
    unsigned long failures = 0;
    std::string last_failure;  // why the last delivery failed, "" after one that did not
  };
  std::vector<Subscription> subscriptions;  // OutPorts only
};

// out_of_reach: it answers on no endpoint this process can use (it serves giop:ssl: only and
// this process has no --tls): maybe alive, never cleaned. not_member: with --tls, the name
// leads to something that is not a member of this system on the name's host (host/tls.h;
// dead_reason says why): never called, never cleaned.
enum class Liveness { alive, dead, out_of_reach, not_member };
inline constexpr std::string_view kOutOfReach = "no usable endpoint";
inline constexpr std::string_view kOutOfReachText =
    "out of reach: it serves no endpoint this process can use (giop:ssl: needs --tls FOLDER)";

struct StatisticInfo {
  std::string name;
  double value = 0;
  std::string unit;
  std::string description;
};

struct ParameterInfo {
  std::string name;
  std::string value;
  std::string unit;
  std::string description;
  std::string access;  // "fixed", "when off", "live"
};

struct ComponentInfo {
  ComponentPath path;
  Liveness liveness = Liveness::alive;
  std::string dead_reason;       // "TRANSIENT" etc. for a dead binding, kOutOfReach, why not a member
  bool extended = false;         // implements RtComponentEx (else a plain seed component)
  std::string kind;
  std::string description;       // one line: what the component does
  std::string state;             // "on", "off", "error", "?" for a seed component
  std::string last_error;
  std::optional<RTM::TimingStats> timing;
  std::optional<RTM::ContractStatus> contract;  // wiring and full; none from a component of before contracts
  std::vector<std::string> members;  // a composite's, in its diagram's order (RTMExt members())
  std::vector<PortInfo> ports;   // InPorts then OutPorts, each in declaration order
  std::vector<StatisticInfo> statistics;  // detailed only
  std::vector<ParameterInfo> parameters;  // detailed only
};

// What a port reference is, once resolved.
struct ResolvedPort {
  std::string address;           // as the user wrote it, normalised "component.port"
  Direction direction;
  std::string name;
  CORBA::Object_var object;      // RTM::InPort or RTM::OutPort
  CORBA::TypeCode_var type;
  std::vector<ElementInfo> elements;  // as the port describes them; empty when it does not
  std::vector<std::string> units() const;  // one per element ("" each when not described)
  std::vector<std::string> names() const;  // one per element (none when not described)
};

enum class Switch { on, off, reset };

class Browser {
 public:
  // call_timeout bounds every remote call, so that a hung process cannot hang the tool.
  Browser(CORBA::ORB_ptr orb, NamingAddress naming, std::chrono::milliseconds call_timeout);

  const NamingClient& naming() const { return naming_; }

  // Every component under filter ("", a host or a component's name, or "host/name"), with ports (and stats when
  // detailed). Dead bindings are reported as dead, not as errors.
  std::vector<ComponentInfo> list(std::string_view filter, bool detailed) const;
  // How much list() asks each component: brief (ls: state, timing, ports), wiring (and each
  // OutPort's subscriptions: what rtm serve draws, twice a second), full (and statistics,
  // parameters, descriptions: ls -l, cat).
  enum class Detail { brief, wiring, full };
  // Asking: parallel (a thread per component: a command's answer in about one component's
  // round trips) or one after another (what a repeated look in the background prefers: one
  // call at a time instead of a burst that every loop waking during it waits behind).
  enum class Asking { parallel, in_turn };
  std::vector<ComponentInfo> list(std::string_view filter, Detail detail, Asking asking = Asking::parallel) const;
  // Removes the dead bindings among those listed; returns their paths.
  std::vector<ComponentPath> clean(std::string_view filter) const;
  // One component in full (ports, counters, subscriptions).
  ComponentInfo describe(std::string_view component) const;

  RTM::RtComponent_var component(std::string_view component) const;
  // on, off or reset of one component (rtm on/off/reset, rtm serve). Throws BrowseError
  // naming the component: "on t: the component is in error; ...", "no component ghost ...".
  void switch_component(const std::string& name, Switch what) const;
  ResolvedPort port(const PortAddress& address) const;

  // subscribe/unsubscribe out -> in. Checks directions and types first, throwing BrowseError
  // "sensor0.out0 (RTM::TimedFloat6) -> ctl.in1 (RTM::TimedFloat3): types differ".
  // A policy other than plain once/repeated needs an OutPortEx (RTMExt.idl's connect).
  void connect(const PortAddress& out, const PortAddress& in, const ConnPolicy& policy) const;
  void disconnect(const PortAddress& out, const PortAddress& in, RTM::ReqType type) const;
  // Both ports resolved and checked as connect() checks them, without subscribing (a system
  // file shown before it is applied).
  std::pair<ResolvedPort, ResolvedPort> pair(const PortAddress& out, const PortAddress& in) const;

  // Sets one parameter; BrowseError with the component's reason when it refuses (unknown
  // name, not writable now, bad value) or is a seed component without parameters. Returns
  // the value the component reports afterwards.
  std::string set_parameter(std::string_view component, const std::string& name, const std::string& value) const;

 private:
  ComponentInfo inspect(const ComponentPath& path, CORBA::Object_ptr object, Detail detail) const;

  CORBA::ORB_var orb_;
  NamingClient naming_;
};

std::string to_string(Direction d);

// The ORB options of a process that browses (rtm, import rtm) through the naming service at
// naming: its own servants (a watch's InPort) take data over giop:unix: from this host's
// components (host/access.h); with a naming service elsewhere also from other hosts, over TCP
// (a component opened with --access open) or, with tls, over giop:ssl:. Every remote call and
// connect is bounded by timeout_ms.
std::vector<std::string> client_orb_arguments(const NamingAddress& naming, bool tls, int timeout_ms);

}  // namespace rtm::cli
