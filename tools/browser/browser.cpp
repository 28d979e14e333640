// SPDX-License-Identifier: Apache-2.0
#include "browser/browser.h"
#include "browser/json.h"

#include "rtm/data.h"
#include "rtm/diagram.h"
#include "host/tls.h"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <future>

namespace rtm::cli {
namespace {

// The system exceptions that mean "the process behind this reference is gone".
template <class F>
std::optional<std::string> dead_if_unreachable(F&& f) {
  try {
    f();
    return std::nullopt;
  } catch (const CORBA::TRANSIENT&) {
    return "TRANSIENT";
  } catch (const CORBA::COMM_FAILURE&) {
    return "COMM_FAILURE";
  } catch (const CORBA::OBJECT_NOT_EXIST&) {
    return "OBJECT_NOT_EXIST";
  } catch (const CORBA::TIMEOUT&) {
    return "TIMEOUT";
  }
}

std::string state_name(RTM::ComponentState s) {
  switch (s) {
    case RTM::COMPONENT_OFF: return "off";
    case RTM::COMPONENT_ON: return "on";
    case RTM::COMPONENT_ERROR: return "error";
  }
  return "?";
}

std::optional<int> indexed(std::string_view port, std::string_view prefix) {
  if (port.size() <= prefix.size() || port.substr(0, prefix.size()) != prefix) return std::nullopt;
  int n = 0;
  auto digits = port.substr(prefix.size());
  auto [ptr, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), n);
  if (ec != std::errc() || ptr != digits.data() + digits.size() || n < 0) return std::nullopt;
  return n;
}

// What an RTMExt port says it carries; nothing from a port that predates describe().
template <class PortEx>
void read_description(PortEx* port, std::string& description, std::vector<ElementInfo>& elements) {
  try {
    RTM::PortDescription_var d = port->describe();
    description = d->description.in();
    for (CORBA::ULong i = 0; i < d->elements.length(); ++i)
      elements.push_back({d->elements[i].name.in(), d->elements[i].unit.in()});
  } catch (const CORBA::BAD_OPERATION&) {
  }
}

const char* access_name(RTM::ParameterAccess access) {
  switch (access) {
    case RTM::PARAMETER_FIXED: return "fixed";
    case RTM::PARAMETER_WHEN_OFF: return "when off";
    case RTM::PARAMETER_LIVE: return "live";
  }
  return "?";
}

// Statistics and parameters of an RTMExt component (none from one that predates them).
void read_self_description(RTM::RtComponentEx_ptr ex, ComponentInfo& info) {
  try {
    CORBA::String_var description = ex->description();
    info.description = description.in();
    RTM::StatisticList_var stats = ex->statistics();
    for (CORBA::ULong i = 0; i < stats->length(); ++i) {
      const RTM::Statistic& s = stats[i];
      info.statistics.push_back({s.name.in(), s.value, s.unit.in(), s.description.in()});
    }
    RTM::ParameterList_var params = ex->parameters();
    for (CORBA::ULong i = 0; i < params->length(); ++i) {
      const RTM::Parameter& p = params[i];
      info.parameters.push_back({p.name.in(), p.value.in(), p.unit.in(), p.description.in(), access_name(p.access)});
    }
  } catch (const CORBA::BAD_OPERATION&) {
  }
}

// Name and type: what every port answers, the seed's too.
template <class Port>
PortInfo basic_info(Port* port, Direction direction, int index) {
  PortInfo info;
  info.direction = direction;
  info.index = index;
  CORBA::String_var name = port->name();
  CORBA::TypeCode_var type = port->port_type();
  info.name = name.in();
  info.type = rtm::type_name(type);
  return info;
}

// What an RTMExt port adds: counters, its last error, what it carries.
template <class PortEx>
void read_extension(PortEx* ex, PortInfo& info) {
  info.extended = true;
  info.counters = ex->counters();
  CORBA::String_var err = ex->last_error();
  info.last_error = err.in();
  read_description(ex, info.description, info.elements);
}

PortInfo inspect_in(RTM::InPort_ptr port, int index) {
  PortInfo info = basic_info(port, Direction::in, index);
  RTM::InPortEx_var ex = RTM::InPortEx::_narrow(port);
  if (!CORBA::is_nil(ex)) read_extension(ex.in(), info);
  return info;
}

PortInfo inspect_out(RTM::OutPort_ptr port, int index) {
  PortInfo info = basic_info(port, Direction::out, index);
  RTM::OutPortEx_var ex = RTM::OutPortEx::_narrow(port);
  if (CORBA::is_nil(ex)) return info;
  read_extension(ex.in(), info);
  RTM::SubscriptionInfoList_var subs = ex->subscriptions();
  for (CORBA::ULong i = 0; i < subs->length(); ++i) {
    const RTM::SubscriptionInfo& s = subs[i];
    std::string policy;
    std::optional<ConnPolicy> asked;
    try {
      policy = rtm::to_string(rtm::from_idl(s.policy));
      asked = rtm::from_idl(s.asked);
    } catch (const std::invalid_argument&) {
      policy = "?";  // a value this build does not know
    }
    info.subscriptions.push_back({s.peer.in(), s.req_type == RTM::once ? "once" : "repeated",
                                  static_cast<bool>(s.in_process), s.path.in(), s.kind.in(), policy, asked,
                                  s.reader.in(), s.pushed, s.dropped, s.failures, s.last_failure.in()});
  }
  return info;
}

}  // namespace

std::string to_string(Direction d) { return d == Direction::in ? "in" : "out"; }

PortAddress PortAddress::parse(std::string_view text) {
  rtm::PortRef ref = rtm::PortRef::parse(text);
  return {std::move(ref.member), std::move(ref.port)};
}

Browser::Browser(CORBA::ORB_ptr orb, NamingAddress naming, std::chrono::milliseconds call_timeout)
    : orb_(CORBA::ORB::_duplicate(orb)), naming_(orb, std::move(naming), call_timeout) {}

ComponentInfo Browser::inspect(const ComponentPath& path, CORBA::Object_ptr object, Detail detail) const {
  ComponentInfo info;
  info.path = path;
  if (tls_configured()) {
    try {
      naming_.check_member(path, object);
    } catch (const NotAMember& e) {
      info.liveness = Liveness::not_member;
      info.dead_reason = e.what();
      return info;
    }
  }
  auto dead = dead_if_unreachable([&] {
    RTM::RtComponentEx_var ex = RTM::RtComponentEx::_narrow(object);
    RTM::RtComponent_var comp;
    if (!CORBA::is_nil(ex)) {
      info.extended = true;
      CORBA::String_var kind = ex->kind();
      info.kind = kind.in();
      info.state = state_name(ex->state());
      CORBA::String_var err = ex->last_error();
      info.last_error = err.in();
      info.timing = ex->timing();
      try {
        RTM::NameList_var members = ex->members();
        for (CORBA::ULong i = 0; i < members->length(); ++i) info.members.emplace_back(members[i].in());
      } catch (const CORBA::BAD_OPERATION&) {
        // an RtComponentEx of before members(): no composite that tools can draw
      }
      if (detail != Detail::brief) {
        try {
          info.contract = ex->contract();
        } catch (const CORBA::BAD_OPERATION&) {
          // an RtComponentEx of before contracts
        }
      }
      if (detail == Detail::full) read_self_description(ex, info);
      comp = RTM::RtComponent::_duplicate(ex);
    } else {
      comp = RTM::RtComponent::_narrow(object);
      if (CORBA::is_nil(comp)) throw BrowseError(path.to_string() + " is not an RtComponent");
      info.state = "?";
    }
    RTM::InPortList_var ins = comp->in_ports();
    RTM::OutPortList_var outs = comp->out_ports();
    // A composite hands out ports its members serve: a member that is gone makes that port
    // unreachable, not the composite dead (it answered above).
    auto add_port = [&](Direction direction, int index, auto inspect) {
      if (auto gone = dead_if_unreachable([&] { info.ports.push_back(inspect()); })) {
        PortInfo p;
        p.direction = direction;
        p.index = index;
        p.name = fmt::format("{}{}", direction == Direction::in ? "in" : "out", index);
        p.type = "?";
        p.last_error = "unreachable (" + *gone + "): the process serving this port is gone";
        info.ports.push_back(std::move(p));
      }
    };
    for (CORBA::ULong i = 0; i < ins->length(); ++i) {
      add_port(Direction::in, static_cast<int>(i), [&] { return inspect_in(ins[i], static_cast<int>(i)); });
    }
    for (CORBA::ULong i = 0; i < outs->length(); ++i) {
      add_port(Direction::out, static_cast<int>(i), [&] { return inspect_out(outs[i], static_cast<int>(i)); });
    }
    if (detail == Detail::brief) {
      for (auto& p : info.ports) p.subscriptions.clear();
    }
  });
  if (dead) {
    // giop:ssl: only and no certificates here: maybe alive, so never called dead or cleaned.
    const bool out_of_reach = !tls_configured() && reachable_only_over_tls(object);
    info.liveness = out_of_reach ? Liveness::out_of_reach : Liveness::dead;
    info.dead_reason = out_of_reach ? std::string(kOutOfReach) : *dead;
    info.ports.clear();
    info.timing.reset();
    info.contract.reset();
  }
  return info;
}

std::vector<ComponentInfo> Browser::list(std::string_view filter, bool detailed) const {
  return list(filter, detailed ? Detail::full : Detail::brief);
}

std::vector<ComponentInfo> Browser::list(std::string_view filter, Detail detail, Asking asking) const {
  std::vector<ComponentEntry> entries = naming_.list_components();
  // "host/name", "host/" or "/name" as written; a bare word is a host or a component's name,
  // as `rtm cat` takes a bare name.
  std::erase_if(entries, [&](const ComponentEntry& e) {
    if (filter.empty()) return false;
    const auto slash = filter.find('/');
    if (slash == std::string_view::npos) return e.path.host != filter && e.path.name != filter;
    const std::string_view host = filter.substr(0, slash), name = filter.substr(slash + 1);
    return (!host.empty() && e.path.host != host) || (!name.empty() && e.path.name != name);
  });
  std::vector<ComponentInfo> out;
  out.reserve(entries.size());
  if (asking == Asking::in_turn) {
    for (const auto& e : entries) out.push_back(inspect(e.path, e.object.in(), detail));
    return out;
  }
  // Components answer independently: ask them in parallel so that a system of many
  // components (or one slow one) costs about one component's round trips.
  std::vector<std::future<ComponentInfo>> answers;
  answers.reserve(entries.size());
  for (const auto& e : entries) {
    answers.push_back(std::async(std::launch::async, [this, &e, detail] {
      return inspect(e.path, e.object.in(), detail);
    }));
  }
  for (auto& a : answers) out.push_back(a.get());
  return out;
}

std::vector<ComponentPath> Browser::clean(std::string_view filter) const {
  std::vector<ComponentPath> removed;
  for (const auto& c : list(filter, false)) {
    if (c.liveness == Liveness::dead) {
      naming_.unbind(c.path);
      removed.push_back(c.path);
    }
  }
  return removed;
}

RTM::RtComponent_var Browser::component(std::string_view name) const {
  RTM::RtComponent_var comp;
  try {
    comp = naming_.resolve_component(name);
  } catch (const NamingError& e) {
    throw BrowseError(e.what());
  }
  if (!tls_configured() && reachable_only_over_tls(comp.in()))
    throw BrowseError(fmt::format("{}: {}", name, kOutOfReachText));
  return comp;
}

void Browser::switch_component(const std::string& name, Switch what) const {
  const char* verb = what == Switch::on ? "on" : what == Switch::off ? "off" : "reset";
  try {
    auto comp = component(name);
    if (what == Switch::on) {
      comp->on();
    } else if (what == Switch::off) {
      comp->off();
    } else {
      RTM::RtComponentEx_var ex = RTM::RtComponentEx::_narrow(comp);
      if (CORBA::is_nil(ex)) throw BrowseError(name + " is a plain RtComponent: it has no reset");
      ex->reset();
    }
  } catch (const CORBA::Exception& e) {
    if (const auto* bio = dynamic_cast<const CORBA::BAD_INV_ORDER*>(&e);
        bio && bio->minor() == rtm::kMinorComponentError) {
      throw BrowseError(fmt::format("{} {}: the component is in error; `rtm cat` shows why, `rtm reset` clears it",
                                    verb, name));
    }
    throw BrowseError(fmt::format("{} {}: {}", verb, name, failure_text(e)));
  }
}

ComponentInfo Browser::describe(std::string_view name) const {
  ComponentPath path = ComponentPath::parse(name);
  RTM::RtComponent_var comp = component(name);
  if (path.host.empty()) {
    for (const auto& e : naming_.list_components()) {
      if (e.path.name == path.name) path = e.path;
    }
  }
  ComponentInfo info = inspect(path, comp.in(), Detail::full);
  if (info.liveness == Liveness::out_of_reach)
    throw BrowseError(fmt::format("{}: {}", path.to_string(), kOutOfReachText));
  if (info.liveness == Liveness::dead) {
    throw BrowseError(fmt::format("{} is bound but its process does not answer ({}); "
                                  "`rtm ls --clean` removes dead bindings",
                                  path.to_string(), info.dead_reason));
  }
  return info;
}

ResolvedPort Browser::port(const PortAddress& address) const {
  RTM::RtComponent_var comp = component(address.component);
  ResolvedPort found{address.to_string(), Direction::in, {}, {}, {}, {}};
  auto dead = dead_if_unreachable([&] {
    RTM::InPortList_var ins = comp->in_ports();
    RTM::OutPortList_var outs = comp->out_ports();
    std::vector<std::string> names;
    auto take = [&](CORBA::Object_ptr obj, Direction dir, const std::string& name,
                    CORBA::TypeCode_ptr type) {
      found.direction = dir;
      found.name = name;
      found.object = CORBA::Object::_duplicate(obj);
      found.type = CORBA::TypeCode::_duplicate(type);
    };
    for (CORBA::ULong i = 0; i < ins->length(); ++i) {
      CORBA::String_var n = ins[i]->name();
      names.push_back(n.in());
      if (address.port == n.in()) {
        CORBA::TypeCode_var t = ins[i]->port_type();
        take(ins[i], Direction::in, n.in(), t);
        return;
      }
    }
    for (CORBA::ULong i = 0; i < outs->length(); ++i) {
      CORBA::String_var n = outs[i]->name();
      names.push_back(n.in());
      if (address.port == n.in()) {
        CORBA::TypeCode_var t = outs[i]->port_type();
        take(outs[i], Direction::out, n.in(), t);
        return;
      }
    }
    if (auto i = indexed(address.port, "in"); i && *i < static_cast<int>(ins->length())) {
      CORBA::String_var n = ins[*i]->name();
      CORBA::TypeCode_var t = ins[*i]->port_type();
      take(ins[*i], Direction::in, n.in(), t);
      return;
    }
    if (auto i = indexed(address.port, "out"); i && *i < static_cast<int>(outs->length())) {
      CORBA::String_var n = outs[*i]->name();
      CORBA::TypeCode_var t = outs[*i]->port_type();
      take(outs[*i], Direction::out, n.in(), t);
      return;
    }
    std::string known;
    for (const auto& n : names) known += (known.empty() ? "" : ", ") + n;
    throw BrowseError(fmt::format("{} has no port '{}' (ports: {}; or in<N>/out<N>)",
                                  address.component, address.port,
                                  known.empty() ? "none" : known));
  });
  if (dead) {
    throw BrowseError(fmt::format("{} does not answer ({}): its process is gone?",
                                  address.component, *dead));
  }
  std::string unused;
  if (found.direction == Direction::in) {
    RTM::InPortEx_var ex = RTM::InPortEx::_narrow(found.object);
    if (!CORBA::is_nil(ex)) read_description(ex.in(), unused, found.elements);
  } else {
    RTM::OutPortEx_var ex = RTM::OutPortEx::_narrow(found.object);
    if (!CORBA::is_nil(ex)) read_description(ex.in(), unused, found.elements);
  }
  return found;
}

std::vector<std::string> ResolvedPort::units() const {
  std::vector<std::string> out;
  for (const auto& e : elements) out.push_back(e.unit);
  return out;
}

std::vector<std::string> ResolvedPort::names() const {
  std::vector<std::string> out;
  for (const auto& e : elements) out.push_back(e.name);
  return out;
}

std::string Browser::set_parameter(std::string_view name, const std::string& parameter,
                                   const std::string& value) const {
  RTM::RtComponent_var comp = component(name);
  RTM::RtComponentEx_var ex = RTM::RtComponentEx::_narrow(comp);
  if (CORBA::is_nil(ex)) throw BrowseError(fmt::format("{} is a plain RtComponent: it has no parameters", name));
  try {
    ex->set_parameter(parameter.c_str(), value.c_str());
    RTM::ParameterList_var params = ex->parameters();
    for (CORBA::ULong i = 0; i < params->length(); ++i) {
      if (parameter == params[i].name.in()) return params[i].value.in();
    }
    return value;
  } catch (const RTM::ParameterRefused& e) {
    throw BrowseError(fmt::format("{}: {}", name, e.reason.in()));  // the reason names the parameter
  }
}

std::pair<ResolvedPort, ResolvedPort> Browser::pair(const PortAddress& out,
                                                    const PortAddress& in) const {
  ResolvedPort o = port(out);
  ResolvedPort i = port(in);
  if (o.direction != Direction::out) {
    throw BrowseError(fmt::format("{} is an InPort; the first port must be an OutPort", o.address));
  }
  if (i.direction != Direction::in) {
    throw BrowseError(fmt::format("{} is an OutPort; the second port must be an InPort", i.address));
  }
  if (!o.type->equivalent(i.type)) {
    throw BrowseError(fmt::format("{} ({}) -> {} ({}): types differ", o.address,
                                  rtm::type_name(o.type), i.address, rtm::type_name(i.type)));
  }
  return {std::move(o), std::move(i)};
}

void Browser::connect(const PortAddress& out, const PortAddress& in, const ConnPolicy& policy) const {
  auto [o, i] = pair(out, in);
  RTM::OutPort_var op = RTM::OutPort::_narrow(o.object);
  RTM::InPort_var ip = RTM::InPort::_narrow(i.object);
  RTM::OutPortEx_var ex = RTM::OutPortEx::_narrow(op);
  // Plain once/repeated is RTM.idl's subscribe, which every OutPort takes.
  const bool plain = policy == ConnPolicy::repeated() || policy == ConnPolicy::one_shot();
  if (!plain && CORBA::is_nil(ex))
    throw BrowseError(fmt::format("{} is a 2004 OutPort: it takes once or repeated, not '{}'", o.address,
                                  rtm::to_string(policy)));
  const bool made = plain ? op->subscribe(policy.once ? RTM::once : RTM::repeated, ip)
                          : ex->connect(rtm::to_idl(policy), ip);
  if (!made) {
    std::string why;
    if (!CORBA::is_nil(ex)) {
      CORBA::String_var err = ex->last_error();
      why = err.in();
    }
    throw BrowseError(fmt::format("{} refused the subscription of {}{}{}", o.address, i.address,
                                  why.empty() ? "" : ": ", why.empty() ? "(already subscribed?)" : why));
  }
}

void Browser::disconnect(const PortAddress& out, const PortAddress& in, RTM::ReqType type) const {
  auto [o, i] = pair(out, in);
  RTM::OutPort_var op = RTM::OutPort::_narrow(o.object);
  RTM::InPort_var ip = RTM::InPort::_narrow(i.object);
  if (!op->unsubscribe(type, ip)) {
    throw BrowseError(fmt::format("{} -> {} ({}) is not connected", o.address, i.address,
                                  type == RTM::once ? "once" : "repeated"));
  }
}

std::vector<std::string> client_orb_arguments(const NamingAddress& naming, bool tls, int timeout_ms) {
  std::vector<std::string> args;
  if (naming.host != "127.0.0.1" && naming.host != "localhost" && naming.host != "::1") {
    args = {"-ORBendPoint", "giop:tcp::", "-ORBendPoint", "giop:unix:"};
    if (tls) args.insert(args.end(), {"-ORBendPoint", "giop:ssl::"});
  }
  args.insert(args.end(), {"-ORBclientCallTimeOutPeriod", std::to_string(timeout_ms), "-ORBclientConnectTimeOutPeriod",
                           std::to_string(timeout_ms)});
  return args;
}

}  // namespace rtm::cli
