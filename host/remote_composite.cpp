// SPDX-License-Identifier: Apache-2.0
#include "host/remote_composite.h"

#include "rtm/log.h"
#include "rtm/orb.h"

#include <fmt/format.h>
#include <spdlog/logger.h>

#include <algorithm>
#include <chrono>
#include <numeric>
#include <stdexcept>
#include <thread>

namespace rtm {

namespace {

// Why an OutPort refused a subscription (an RTM::OutPortEx says it; a plain OutPort cannot).
std::string refusal_of(RTM::OutPort_ptr port) {
  try {
    RTM::OutPortEx_var ex = RTM::OutPortEx::_narrow(port);
    if (!CORBA::is_nil(ex)) {
      CORBA::String_var why = ex->last_error();
      return why.in();
    }
  } catch (const CORBA::Exception& e) {
    return std::string("CORBA ") + e._name();
  }
  return "refused";
}

// The port of a remote component named `port`, or "in<N>"/"out<N>" (a 2004 component whose
// ports say no name of use); nil when it has none. names: each port's name, for a message.
template <class List, class Port>
typename Port::_ptr_type find_port(const List& ports, const std::string& port, const char* prefix,
                                   std::vector<std::string>* names = nullptr) {
  for (CORBA::ULong i = 0; i < ports.length(); ++i) {
    CORBA::String_var n = ports[i]->name();
    if (names) names->push_back(n.in());
    if (port == n.in() || port == prefix + std::to_string(i)) return Port::_duplicate(ports[i]);
  }
  return Port::_nil();
}

RTM::InPort_ptr find_in(RTM::RtComponent_ptr c, const std::string& port, std::vector<std::string>* names = nullptr) {
  RTM::InPortList_var ins = c->in_ports();
  return find_port<RTM::InPortList, RTM::InPort>(ins.in(), port, "in", names);
}

RTM::OutPort_ptr find_out(RTM::RtComponent_ptr c, const std::string& port, std::vector<std::string>* names = nullptr) {
  RTM::OutPortList_var outs = c->out_ports();
  return find_port<RTM::OutPortList, RTM::OutPort>(outs.in(), port, "out", names);
}

// What a remote port is, for the diagram's check: its type, and its elements' units when it
// describes them (an RTMExt port).
template <class Ex, class Port>
PortShape shape_of(Port* port, bool is_in) {
  CORBA::TypeCode_var type = port->port_type();
  PortShape shape{is_in, type_name(type.in()), {}};
  typename Ex::_var_type ex = Ex::_narrow(port);
  if (!CORBA::is_nil(ex)) {
    RTM::PortDescription_var d = ex->describe();
    for (CORBA::ULong i = 0; i < d->elements.length(); ++i) shape.units.push_back(d->elements[i].unit.in());
  }
  return shape;
}

std::string join(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + n;
  return out.empty() ? "none" : out;
}

}  // namespace

RemoteComposite::RemoteComposite(std::string name, std::string kind, Diagram diagram, std::vector<Member> members)
    : Component(std::move(name), std::move(kind)), diagram_(std::move(diagram)) {
  if (diagram_.ticked)
    throw std::invalid_argument(this->name() + ": diagram " + diagram_.name +
                                " is ticked: its members cannot run on a tick of this process");
  diagram_.check_structure();
  std::vector<std::string> names;
  for (const auto& m : members) names.push_back(m.name);
  for (const std::size_t i : diagram_.arrange(names, this->name())) {
    if (CORBA::is_nil(members[i].ref))
      throw std::invalid_argument(this->name() + ": the reference of " + members[i].name + " is nil");
    members_.push_back(std::move(members[i]));
  }
  std::vector<std::string> in_order;
  for (const auto& m : members_) in_order.push_back(m.name);
  set_member_names(std::move(in_order));
}

RemoteComposite::~RemoteComposite() = default;

RTM::RtComponent_ptr RemoteComposite::member(const std::string& name) const {
  for (const auto& m : members_) {
    if (m.name == name) return m.ref.in();
  }
  return RTM::RtComponent::_nil();
}

RTM::InPort_ptr RemoteComposite::in_port(const PortRef& port) const {
  RTM::RtComponent_ptr m = member(port.member);
  if (CORBA::is_nil(m)) throw std::runtime_error(fmt::format("{}: no member {}", name(), port.member));
  std::vector<std::string> names;
  RTM::InPort_var in = find_in(m, port.port, &names);
  if (CORBA::is_nil(in))
    throw std::runtime_error(
        fmt::format("{}: {} has no InPort {} (InPorts: {})", name(), port.member, port.port, join(names)));
  return in._retn();
}

std::vector<RemoteComposite::Link> RemoteComposite::links() const {
  const PortCatalogue ports{
      .find = [this](const PortRef& ref, bool in) -> std::optional<PortShape> {
        RTM::RtComponent_ptr m = member(ref.member);
        if (CORBA::is_nil(m)) return std::nullopt;
        if (in) {
          RTM::InPort_var p = find_in(m, ref.port);
          if (!CORBA::is_nil(p)) return shape_of<RTM::InPortEx>(p.in(), true);
        } else {
          RTM::OutPort_var p = find_out(m, ref.port);
          if (!CORBA::is_nil(p)) return shape_of<RTM::OutPortEx>(p.in(), false);
        }
        return std::nullopt;
      },
      .names = [this](const std::string& name, bool in) {
        std::vector<std::string> names;
        RTM::RtComponent_ptr m = member(name);
        if (CORBA::is_nil(m)) return names;
        if (in) {
          RTM::InPort_var ignored = find_in(m, "", &names);
        } else {
          RTM::OutPort_var ignored = find_out(m, "", &names);
        }
        return names;
      },
  };
  diagram_.check(ports);
  std::vector<Link> result;
  for (const auto& c : diagram_.connections) {
    result.push_back({find_out(member(c.from.member), c.from.port), find_in(member(c.to.member), c.to.port), c.text()});
  }
  return result;
}

std::vector<std::size_t> RemoteComposite::turn_on_order() const {
  std::vector<std::size_t> order(members_.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  const bool paced = std::any_of(diagram_.members.begin(), diagram_.members.end(),
                                 [](const Diagram::Member& m) { return m.phase_ns != 0; });
  if (!paced) {
    std::reverse(order.begin(), order.end());
  } else {
    std::stable_sort(order.begin(), order.end(),
                     [this](std::size_t a, std::size_t b) { return diagram_.members[a].phase_ns < diagram_.members[b].phase_ns; });
  }
  return order;
}

void RemoteComposite::undo(const std::vector<std::size_t>& turned_on, const std::vector<Link>& subscribed) {
  for (auto it = turned_on.rbegin(); it != turned_on.rend(); ++it) {
    const Member& m = members_[*it];
    try {
      m.ref->off();
    } catch (const CORBA::Exception& e) {
      log().warn("{}: off() of {} raised {}", name(), m.name, e._name());
    }
  }
  for (const auto& l : subscribed) {
    try {
      l.from->unsubscribe(RTM::repeated, l.to);
    } catch (const CORBA::Exception& e) {
      log().warn("{}: unsubscribing {} raised {}", name(), l.text, e._name());
    }
  }
}

void RemoteComposite::on_start() {
  std::vector<std::size_t> turned_on;
  std::vector<Link> subscribed;
  const std::vector<std::size_t> order = turn_on_order();
  std::string step = "check the wiring";
  try {
    for (const Link& l : links()) {
      step = "subscribe " + l.text;
      // A subscription left from an earlier run (a crash between on and off) is replaced.
      l.from->unsubscribe(RTM::repeated, l.to);
      if (!l.from->subscribe(RTM::repeated, l.to)) throw std::runtime_error(step + ": " + refusal_of(l.from));
      subscribed.push_back(l);
    }
    const auto first = std::chrono::steady_clock::now();
    for (const std::size_t i : order) {
      std::this_thread::sleep_until(first + std::chrono::nanoseconds(diagram_.members[i].phase_ns));
      step = "on() " + members_[i].name;
      members_[i].ref->on();
      turned_on.push_back(i);
    }
  } catch (const CORBA::Exception& e) {
    undo(turned_on, subscribed);
    throw std::runtime_error(fmt::format("{}: {} raised {}", name(), step, e._name()));
  } catch (const std::exception& e) {
    undo(turned_on, subscribed);
    throw std::runtime_error(fmt::format("{}: {}", name(), e.what()));
  }
  std::vector<RTM::RtComponentEx_var> held;
  for (const auto& m : members_) {
    RTM::RtComponentEx_var ex = RTM::RtComponentEx::_narrow(m.ref.in());
    if (!CORBA::is_nil(ex)) held.push_back(ex);  // a plain RtComponent cannot be held
  }
  holds_ = std::make_unique<HoldRenewal>(name(), std::move(held), kLeaseMs);
  std::string text;
  for (const std::size_t i : order) {
    text += fmt::format("{}{}", text.empty() ? "" : ", ", members_[i].name);
    if (diagram_.members[i].phase_ns != 0) text += fmt::format(" at +{} us", diagram_.members[i].phase_ns / 1000);
  }
  log().info("{}: members connected and on ({})", name(), text);
}

void RemoteComposite::on_stop() {
  std::vector<std::size_t> all(members_.size());
  std::iota(all.begin(), all.end(), std::size_t{0});  // undone last first
  undo(all, {});
  holds_.reset();
  std::vector<Link> made;
  try {
    made = links();
  } catch (const std::exception& e) {
    log().warn("{}: finding its connections to remove: {}", name(), e.what());
  } catch (const CORBA::Exception& e) {
    log().warn("{}: finding its connections to remove raised {}", name(), e._name());
  }
  undo({}, made);
  log().info("{}: members off and disconnected", name());
}

}  // namespace rtm
