// SPDX-License-Identifier: Apache-2.0
#include "rtm/diagram.h"

#include "rtm/component.h"
#include "rtm/data.h"

#include <fmt/format.h>

#include <charconv>
#include <map>
#include <set>

namespace rtm {

namespace {

std::string joined(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + n;
  return out.empty() ? "none" : out;
}

// "in3" -> 3 when text is prefix + digits, else nullopt.
std::optional<std::size_t> index_alias(std::string_view text, std::string_view prefix) {
  if (!text.starts_with(prefix) || text.size() == prefix.size()) return std::nullopt;
  std::size_t index = 0;
  const auto* first = text.data() + prefix.size();
  const auto [end, ec] = std::from_chars(first, text.data() + text.size(), index);
  if (ec != std::errc{} || end != text.data() + text.size()) return std::nullopt;
  return index;
}

template <class Port>
Port* find_port(const std::vector<Port*>& ports, std::string_view name, std::string_view prefix) {
  for (auto* p : ports) {
    if (p->port_name() == name) return p;
  }
  if (const auto index = index_alias(name, prefix); index && *index < ports.size()) return ports[*index];
  return nullptr;
}

template <class Port>
PortShape shape_of(const Port& port, bool is_in) {
  PortShape shape{is_in, type_name(port.type_code()), {}};
  for (const auto& e : port.info().elements) shape.units.push_back(e.unit);
  return shape;
}

std::string unit_text(const std::string& unit) { return unit.empty() ? "no unit" : unit; }

}  // namespace

PortRef PortRef::parse(std::string_view text) {
  const auto dot = text.rfind('.');
  if (dot == std::string_view::npos || dot == 0 || dot + 1 == text.size())
    throw std::invalid_argument(
        fmt::format("'{}' is not a port address: expected <component>.<port>, e.g. sensor0.out0", text));
  return {std::string(text.substr(0, dot)), std::string(text.substr(dot + 1))};
}

InPortBase* in_port_of(const Component& component, std::string_view port) {
  return find_port(component.in_ports(), port, "in");
}

OutPortBase* out_port_of(const Component& component, std::string_view port) {
  return find_port(component.out_ports(), port, "out");
}

PortCatalogue catalogue_of(const std::vector<const Component*>& members) {
  auto member = [members](const std::string& name) -> const Component* {
    for (const auto* m : members) {
      if (m->name() == name) return m;
    }
    return nullptr;
  };
  return {
      .find = [member](const PortRef& ref, bool in) -> std::optional<PortShape> {
        const Component* m = member(ref.member);
        if (!m) return std::nullopt;
        if (in) {
          if (const auto* port = in_port_of(*m, ref.port)) return shape_of(*port, true);
        } else if (const auto* port = out_port_of(*m, ref.port)) {
          return shape_of(*port, false);
        }
        return std::nullopt;
      },
      .names = [member](const std::string& name, bool in) {
        std::vector<std::string> names;
        if (const Component* m = member(name)) {
          if (in) {
            for (const auto* p : m->in_ports()) names.push_back(p->port_name());
          } else {
            for (const auto* p : m->out_ports()) names.push_back(p->port_name());
          }
        }
        return names;
      },
  };
}

DiagramError::DiagramError(const std::string& diagram, std::vector<std::string> problems)
    : std::invalid_argument([&] {
        std::string text = fmt::format("{}: {} problem{}", diagram, problems.size(), problems.size() == 1 ? "" : "s");
        for (const auto& p : problems) text += "\n  " + p;
        return text;
      }()),
      problems_(std::move(problems)) {}

std::vector<std::size_t> Diagram::arrange(const std::vector<std::string>& given, std::string_view owner) const {
  std::vector<std::size_t> order;
  std::vector<bool> taken(given.size(), false);
  for (const auto& m : members) {
    std::size_t i = 0;
    while (i < given.size() && (taken[i] || given[i] != m.name)) ++i;
    if (i == given.size()) throw std::invalid_argument(fmt::format("{}: diagram member {} was not given", owner, m.name));
    taken[i] = true;
    order.push_back(i);
  }
  for (std::size_t i = 0; i < given.size(); ++i) {
    if (!taken[i]) throw std::invalid_argument(fmt::format("{}: member {} is not in the diagram", owner, given[i]));
  }
  return order;
}

std::vector<std::string> Diagram::problems(const PortCatalogue* ports) const {
  std::vector<std::string> out;
  std::map<std::string, std::size_t> position;
  std::vector<std::string> names;
  for (const auto& m : members) {
    if (m.name.empty()) out.push_back("a member has no name");
    if (!position.emplace(m.name, position.size()).second) out.push_back(fmt::format("member {} is listed twice", m.name));
    names.push_back(m.name);
    if (m.phase_ns < 0 || (period_ns > 0 && m.phase_ns >= period_ns))
      out.push_back(fmt::format("member {}: phase {} ns is not within the period [0, {} ns)", m.name, m.phase_ns,
                                period_ns));
  }
  std::set<std::pair<std::string, std::string>> listed;
  std::map<std::string, const Connection*> writers;  // InPort -> its first writer
  for (const auto& c : connections) {
    bool known = true;
    for (const auto* end : {&c.from, &c.to}) {
      if (!position.contains(end->member)) {
        out.push_back(fmt::format("{}: no member {} (members: {})", c.text(), end->member, joined(names)));
        known = false;
      }
    }
    if (!listed.emplace(c.from.to_string(), c.to.to_string()).second) {
      out.push_back(fmt::format("{} is listed twice", c.text()));
      continue;
    }
    if (const auto [first, added] = writers.emplace(c.to.to_string(), &c); !added) {
      out.push_back(fmt::format("{} has two writers, {} and {}: an InPort takes one", c.to.to_string(),
                                first->second->from.to_string(), c.from.to_string()));
    }
    if (known && ticked && !c.feedback && position[c.from.member] >= position[c.to.member]) {
      out.push_back(fmt::format(
          "{} runs against the tick order ({} runs {} {} in each cycle): list {} first, or declare the connection "
          "feedback (read one cycle later)",
          c.text(), c.to.member, c.from.member == c.to.member ? "as" : "before", c.from.member, c.from.member));
    }
    if (!known || !ports) continue;
    const auto from = ports->find(c.from, false);
    const auto to = ports->find(c.to, true);
    auto missing = [&](const PortRef& end, bool in) {
      const char* kind = in ? "InPort" : "OutPort";
      if (ports->find(end, !in))
        return fmt::format("{}: {} is {}; a connection goes from an OutPort to an InPort", c.text(), end.to_string(),
                           in ? "an OutPort" : "an InPort");
      const auto have = ports->names ? ports->names(end.member, in) : std::vector<std::string>{};
      return fmt::format("{}: {} has no {} {} ({}s: {})", c.text(), end.member, kind, end.port, kind, joined(have));
    };
    if (!from) out.push_back(missing(c.from, false));
    if (!to) out.push_back(missing(c.to, true));
    if (!from || !to) continue;
    if (from->type != to->type) {
      out.push_back(fmt::format("{} ({}) -> {} ({}): types differ", c.from.to_string(), from->type, c.to.to_string(),
                                to->type));
      continue;
    }
    if (from->units.empty() || to->units.empty() || from->units.size() != to->units.size()) continue;
    for (std::size_t i = 0; i < from->units.size(); ++i) {
      if (from->units[i] == to->units[i]) continue;
      out.push_back(fmt::format("{}: element {} is in {} at {} and in {} at {}", c.text(), i,
                                unit_text(from->units[i]), c.from.to_string(), unit_text(to->units[i]),
                                c.to.to_string()));
      break;
    }
  }
  return out;
}

void Diagram::check(const PortCatalogue& ports) const {
  if (auto found = problems(&ports); !found.empty()) throw DiagramError(name, std::move(found));
}

void Diagram::check_structure() const {
  if (auto found = problems(); !found.empty()) throw DiagramError(name, std::move(found));
}

}  // namespace rtm
