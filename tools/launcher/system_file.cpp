// SPDX-License-Identifier: Apache-2.0
#include "launcher/system_file.h"

#include "rtm/naming.h"
#include "rt/schedule.h"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>

namespace rtm::cli {
namespace {

[[noreturn]] void fail(const SystemFile& f, const YAML::Node& at, const std::string& what) {
  const YAML::Mark mark = at.Mark();
  if (mark.line >= 0) {
    throw SystemFileError(fmt::format("{}:{}: {}", f.path.string(), mark.line + 1, what));
  }
  throw SystemFileError(fmt::format("{}: {}", f.path.string(), what));
}

std::string scalar(const SystemFile& f, const YAML::Node& node, const std::string& what) {
  if (!node || !node.IsScalar() || node.as<std::string>().empty()) {
    fail(f, node, what + " must be a non-empty string");
  }
  return node.as<std::string>();
}

// map[key] as a non-empty string; a missing key is reported at the mapping's line (a missing
// node has no place in the file of its own).
std::string scalar_field(const SystemFile& f, const YAML::Node& map, const char* key, const std::string& what) {
  const YAML::Node node = map[key];
  if (!node) fail(f, map, what + " is missing");
  return scalar(f, node, what);
}

// A component's 'parameters' (or one of its sets; owner names which, "component 'c'"): a mapping
// of names to a number, a list of numbers, or text, each kept as the text `rtm set` takes. The
// component itself checks the values when `rtm up` sets them.
SystemFile::Component::Parameters parse_parameters(const SystemFile& f, const YAML::Node& node,
                                                   const std::string& owner) {
  if (!node.IsMap()) fail(f, node, fmt::format("{}: 'parameters' must be a mapping of names to values", owner));
  SystemFile::Component::Parameters out;
  for (const auto& kv : node) {
    const std::string name = scalar(f, kv.first, "a parameter's name");
    std::string value;
    if (kv.second.IsSequence() && kv.second.size() > 0) {
      for (const auto& v : kv.second) {
        if (!value.empty()) value += ' ';
        value += scalar(f, v, fmt::format("a value of '{}'", name));
      }
    } else {
      value = scalar(f, kv.second, fmt::format("{}: parameter '{}'", owner, name));
    }
    for (const auto& [seen, ignored] : out) {
      if (seen == name) fail(f, kv.first, fmt::format("{}: parameter '{}' given twice", owner, name));
    }
    out.emplace_back(name, std::move(value));
  }
  return out;
}

// A component's 'contract': each key and its text, checked here so that a typo is refused with
// its line before anything starts (the program checks the whole contract again).
std::vector<std::pair<std::string, std::string>> parse_contract(const SystemFile& f, const YAML::Node& node,
                                                                const std::string& owner) {
  static const char* const kKeys = "period, phase, deadline, budget, await, cpu, priority, sched_deadline, on_miss";
  if (!node.IsMap()) fail(f, node, fmt::format("{}: 'contract' must be a mapping ({})", owner, kKeys));
  std::vector<std::pair<std::string, std::string>> out;
  for (const auto& kv : node) {
    const std::string key = scalar(f, kv.first, "a contract's key");
    const std::string text = scalar(f, kv.second, fmt::format("{}: contract '{}'", owner, key));
    const auto bad = [&](const std::string& want) {
      fail(f, kv.second, fmt::format("{}: contract {} '{}': want {}", owner, key, text, want));
    };
    const std::optional<double> ns = parse_duration_ns(text);
    if (key == "period") {
      if (!ns || *ns < 50e3 || *ns > 3600e9) bad("a duration from 50us to 1 h, e.g. 2ms");
    } else if (key == "phase") {
      if (!ns || *ns < 0) bad("a duration from 0 to less than the period, e.g. 0.1ms");
    } else if (key == "deadline" || key == "budget" || key == "sched_deadline") {
      if (!ns || *ns < 1) bad("a duration above 0, e.g. 0.5ms or 80us");
    } else if (key == "await") {
      const std::size_t colon = text.find(':');
      if (colon == 0 || colon == std::string::npos || !parse_duration_ns(text.substr(colon + 1)))
        bad("PORT:BOUND, e.g. wrench:0.15ms");
    } else if (key == "cpu" || key == "priority") {
      int value = -1;
      const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
      if (ec != std::errc{} || end != text.data() + text.size() || value < (key == "cpu" ? 0 : 1) || value > (key == "cpu" ? 4095 : 99))
        bad(key == "cpu" ? "a CPU's number, from 0" : "a SCHED_FIFO priority, 1..99");
    } else if (key == "on_miss") {
      if (!rtm::parse_miss_action(text)) bad("count, warn or brake");
    } else {
      fail(f, kv.first, fmt::format("{}: unknown key '{}' in a contract (known: {})", owner, key, kKeys));
    }
    for (const auto& [seen, ignored] : out)
      if (seen == key) fail(f, kv.first, fmt::format("{}: contract '{}' given twice", owner, key));
    out.emplace_back(key, text);
  }
  const auto has = [&](const char* key) {
    return std::any_of(out.begin(), out.end(), [&](const auto& kv) { return kv.first == key; });
  };
  if (has("sched_deadline") && (has("priority") || has("cpu")))
    fail(f, node, fmt::format("{}: a contract with sched_deadline takes no priority and no cpu (the kernel refuses "
                              "SCHED_DEADLINE for a thread pinned to one CPU)", owner));
  return out;
}

// One entry of 'chains': a name, a path through components the file lists, its bounds.
rtm::ChainContract parse_chain(const SystemFile& f, const YAML::Node& c, const std::set<std::string>& names) {
  if (!c.IsMap()) fail(f, c, "each chain must be a mapping with 'name' and 'path'");
  for (const auto& kv : c) {
    const auto key = kv.first.as<std::string>();
    if (key != "name" && key != "path" && key != "deadline" && key != "max_age" && key != "on_miss")
      fail(f, kv.first, fmt::format("unknown key '{}' in a chain (known: name, path, deadline, max_age, on_miss)", key));
  }
  rtm::ChainContract chain;
  chain.name = scalar_field(f, c, "name", "a chain's 'name'");
  try {
    rtm::check_name(chain.name, "chain name");
  } catch (const std::invalid_argument& e) {
    fail(f, c["name"], e.what());
  }
  const YAML::Node path = c["path"];
  if (!path || !path.IsSequence() || path.size() < 2)
    fail(f, path ? path : c,
         fmt::format("chain '{}': 'path' must list the head's OutPort and then each component the data pass, e.g. "
                     "[sensor0.wrench, controller0, actuator0]", chain.name));
  for (std::size_t i = 0; i < path.size(); ++i) {
    const std::string step = scalar(f, path[i], fmt::format("chain '{}': a step of 'path'", chain.name));
    const std::size_t dot = step.find('.');
    const std::string component = step.substr(0, dot);
    if (i == 0 && (dot == std::string::npos || dot + 1 == step.size()))
      fail(f, path[i], fmt::format("chain '{}': its path starts at an OutPort, component.port, not '{}'", chain.name, step));
    if (i > 0 && dot != std::string::npos && (dot + 1 == step.size() || step.find('.', dot + 1) != std::string::npos))
      fail(f, path[i], fmt::format("chain '{}': after its head the path names components, or component.inport, not '{}'",
                                   chain.name, step));
    if (!names.count(component))
      fail(f, path[i], fmt::format("chain '{}' names component '{}', which 'components' does not list", chain.name, component));
    chain.path.push_back(step);
  }
  for (const auto& [key, field] : {std::pair{"deadline", &chain.deadline_ns}, std::pair{"max_age", &chain.max_age_ns}}) {
    const YAML::Node n = c[key];
    if (!n) continue;
    const std::string text = scalar(f, n, fmt::format("chain '{}': '{}'", chain.name, key));
    const std::optional<double> ns = parse_duration_ns(text);
    if (!ns || *ns < 1) fail(f, n, fmt::format("chain '{}': {} '{}': want a duration above 0, e.g. 1ms", chain.name, key, text));
    *field = std::llround(*ns);
  }
  if (const YAML::Node n = c["on_miss"]) {
    const std::string text = scalar(f, n, fmt::format("chain '{}': 'on_miss'", chain.name));
    const std::optional<rtm::MissAction> on_miss = rtm::parse_miss_action(text);
    if (!on_miss) fail(f, n, fmt::format("chain '{}': on_miss '{}': want count, warn or brake", chain.name, text));
    chain.on_miss = *on_miss;
  }
  return chain;
}

// One entry of 'components': its name (the one name rule), its command and its parameters.
SystemFile::Component parse_component(const SystemFile& f, const YAML::Node& c) {
  SystemFile::Component comp;
  for (const auto& kv : c) {
    const auto key = kv.first.as<std::string>();
    if (key != "name" && key != "command" && key != "host" && key != "parameters" && key != "parameter_sets" &&
        key != "contract")
      fail(f, kv.first,
           fmt::format("unknown key '{}' in a component (known: name, command, host, parameters, parameter_sets, "
                       "contract)",
                       key));
  }
  comp.name = scalar_field(f, c, "name", "a component's 'name'");
  try {
    rtm::check_name(comp.name);  // it names the component's log file
  } catch (const std::invalid_argument& e) {
    fail(f, c["name"], e.what());
  }
  const YAML::Node cmd = c["command"];
  if (cmd && cmd.IsScalar()) {
    comp.command.push_back(cmd.as<std::string>());
  } else if (cmd && cmd.IsSequence() && cmd.size() > 0) {
    for (const auto& w : cmd) comp.command.push_back(scalar(f, w, "a command word"));
  } else {
    fail(f, cmd ? cmd : c,
         fmt::format("component '{}' needs a 'command' (program, or list of program and arguments)", comp.name));
  }
  const std::string owner = fmt::format("component '{}'", comp.name);
  if (const YAML::Node host = c["host"]) {
    comp.host = scalar(f, host, fmt::format("{}: 'host'", owner));
    try {
      rtm::check_name(comp.host, "host name");  // it names the process's log file
    } catch (const std::invalid_argument& e) {
      fail(f, host, e.what());
    }
    // rtm-container takes its members' commands apart at each '--'.
    for (std::size_t i = 0; i < comp.command.size(); ++i) {
      if (comp.command[i] == "--")
        fail(f, cmd.IsSequence() ? cmd[i] : cmd,
             fmt::format("{} runs in host '{}': its command may not hold '--' (rtm-container separates its members "
                         "with it)",
                         owner, comp.host));
    }
  }
  if (const YAML::Node params = c["parameters"]) comp.parameters = parse_parameters(f, params, owner);
  if (const YAML::Node contract = c["contract"]) comp.contract = parse_contract(f, contract, owner);
  if (const YAML::Node sets = c["parameter_sets"]) {
    if (!sets.IsMap())
      fail(f, sets, fmt::format("{}: 'parameter_sets' must map set names to parameters", owner));
    for (const auto& kv : sets) {
      const std::string set = scalar(f, kv.first, "a parameter set's name");
      comp.parameter_sets.emplace_back(set, parse_parameters(f, kv.second, fmt::format("{} set '{}'", owner, set)));
    }
  }
  return comp;
}

// One entry of 'connections': its ends (components the file lists) and its policy ('type'
// and 'policy' must not disagree on once/repeated).
SystemFile::Connection parse_connection(const SystemFile& f, const YAML::Node& c, const std::set<std::string>& names) {
  using Connection = SystemFile::Connection;
  if (!c.IsMap()) fail(f, c, "each connection must be a mapping with 'from' and 'to'");
  for (const auto& kv : c) {
    const auto key = kv.first.as<std::string>();
    if (key != "from" && key != "to" && key != "type" && key != "policy")
      fail(f, kv.first, fmt::format("unknown key '{}' in a connection (known: from, to, type, policy)", key));
  }
  Connection conn{scalar_field(f, c, "from", "a connection's 'from'"),
                  scalar_field(f, c, "to", "a connection's 'to'"), {}};
  std::optional<bool> once;
  if (const YAML::Node t = c["type"]) {
    const auto type = scalar(f, t, "a connection's 'type'");
    if (type != "once" && type != "repeated") {
      fail(f, t, fmt::format("connection type '{}' is neither 'once' nor 'repeated'", type));
    }
    once = type == "once";
  }
  const YAML::Node p = c["policy"];
  try {
    conn.policy = parse_conn_policy(p ? scalar(f, p, "a connection's 'policy'") : "", once);
  } catch (const std::invalid_argument& e) {
    fail(f, p ? p : c, e.what());
  }
  for (const auto* end : {&conn.from, &conn.to}) {
    std::string member;
    try {
      member = rtm::PortRef::parse(*end).member;
    } catch (const std::invalid_argument& e) {
      fail(f, c, e.what());
    }
    if (!names.count(member)) {
      fail(f, c, fmt::format("'{}' names component '{}', which 'components' does not list", *end, member));
    }
  }
  return conn;
}

}  // namespace

SystemFile SystemFile::load(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw SystemFileError(fmt::format("{}: cannot read the system file", file.string()));
  std::stringstream text;
  text << in.rdbuf();
  return parse(text.str(), std::filesystem::absolute(file));
}

SystemFile SystemFile::parse(const std::string& yaml_text, const std::filesystem::path& path) {
  SystemFile f;
  f.path = path;
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw SystemFileError(fmt::format("{}:{}: not valid YAML: {}", path.string(), e.mark.line + 1, e.msg));
  }
  if (!root.IsMap()) fail(f, root, "expected a mapping with 'components'");
  for (const auto& kv : root) {
    const auto key = kv.first.as<std::string>();
    if (key != "name" && key != "naming" && key != "components" && key != "connections" &&
        key != "activate" && key != "chains") {
      fail(f, kv.first, fmt::format("unknown key '{}' (known: name, naming, components, "
                                    "connections, activate, chains)", key));
    }
  }
  f.name = root["name"] ? scalar(f, root["name"], "'name'") : path.stem().string();
  try {
    rtm::check_name(f.name, "system name");  // it names the state file and the log folder
  } catch (const std::invalid_argument& e) {
    fail(f, root["name"] ? root["name"] : root, e.what());
  }
  if (root["naming"]) f.naming = scalar(f, root["naming"], "'naming'");

  const YAML::Node comps = root["components"];
  if (!comps || !comps.IsSequence() || comps.size() == 0) {
    fail(f, comps ? comps : root, "'components' must be a non-empty list");
  }
  std::set<std::string> names;
  for (const auto& c : comps) {
    if (!c.IsMap()) fail(f, c, "each component must be a mapping with 'name' and 'command'");
    SystemFile::Component comp = parse_component(f, c);
    if (!names.insert(comp.name).second) fail(f, c, fmt::format("component '{}' listed twice", comp.name));
    f.components.push_back(std::move(comp));
  }
  // A host's name is its process's: it must not be taken for a component's.
  for (std::size_t i = 0; i < f.components.size(); ++i) {
    const auto& c = f.components[i];
    if (!c.host.empty() && names.count(c.host))
      fail(f, comps[i]["host"],
           fmt::format("component '{}': host '{}' is also a component's name (a host needs a name of its own)", c.name,
                       c.host));
  }

  if (const YAML::Node conns = root["connections"]) {
    if (!conns.IsSequence()) fail(f, conns, "'connections' must be a list");
    for (const auto& c : conns) {
      f.connections.push_back(parse_connection(f, c, names));
    }
  }

  if (const YAML::Node act = root["activate"]) {
    if (!act.IsSequence()) fail(f, act, "'activate' must be a list of component names");
    for (const auto& a : act) {
      auto n = scalar(f, a, "an 'activate' entry");
      if (!names.count(n)) fail(f, a, fmt::format("'activate' names '{}', which 'components' does not list", n));
      f.activate.push_back(std::move(n));
    }
  }
  if (const YAML::Node chains = root["chains"]) {
    if (!chains.IsSequence()) fail(f, chains, "'chains' must be a list");
    for (const auto& c : chains) {
      f.chains.push_back(parse_chain(f, c, names));
      for (std::size_t i = 0; i + 1 < f.chains.size(); ++i)
        if (f.chains[i].name == f.chains.back().name)
          fail(f, c, fmt::format("chain '{}' listed twice", f.chains.back().name));
    }
  }
  // What the file's wiring is as a diagram: an InPort written twice, a connection listed twice.
  if (auto problems = f.diagram().problems(); !problems.empty()) {
    std::string text = fmt::format("{}: the wiring does not hold:", path.string());
    for (const auto& p : problems) text += "\n  " + p;
    throw SystemFileError(text);
  }
  return f;
}

SystemFile::Component::Parameters SystemFile::Component::parameters_with(const std::string& set) const {
  Parameters out = parameters;
  for (const auto& [name, values] : parameter_sets) {
    if (name != set) continue;
    for (const auto& [parameter, value] : values) {
      const auto it = std::find_if(out.begin(), out.end(), [&](const auto& p) { return p.first == parameter; });
      if (it != out.end())
        it->second = value;
      else
        out.emplace_back(parameter, value);
    }
  }
  return out;
}

std::vector<std::string> SystemFile::Component::arguments() const {
  static const std::pair<const char*, const char*> kOptions[] = {
      {"period", "--period"}, {"phase", "--phase"},       {"deadline", "--deadline"},
      {"budget", "--budget"}, {"await", "--await"},       {"cpu", "--cpu"},
      {"priority", "--rt-priority"}, {"sched_deadline", "--sched-deadline"}, {"on_miss", "--on-miss"}};
  std::vector<std::string> out = command;
  for (const auto& [key, text] : contract) {
    for (const auto& [name, option] : kOptions)
      if (key == name) out.insert(out.end(), {option, text});
  }
  return out;
}

namespace {

std::string component_of(const std::string& step) { return step.substr(0, step.find('.')); }
std::string port_of(const std::string& step) {
  const std::size_t dot = step.find('.');
  return dot == std::string::npos ? std::string() : step.substr(dot + 1);
}

}  // namespace

std::vector<std::pair<std::string, std::vector<std::string>>> SystemFile::stamp_derivations(
    const Component& component) const {
  std::vector<std::pair<std::string, std::vector<std::string>>> out;  // OutPort -> its InPorts
  const auto add = [&out](const std::string& out_port, const std::string& in_port) {
    auto it = std::find_if(out.begin(), out.end(), [&](const auto& d) { return d.first == out_port; });
    if (it == out.end()) it = out.insert(out.end(), {out_port, {}});
    if (std::find(it->second.begin(), it->second.end(), in_port) == it->second.end()) it->second.push_back(in_port);
  };
  for (const auto& chain : chains) {
    for (std::size_t i = 1; i + 1 < chain.path.size(); ++i) {
      if (component_of(chain.path[i]) != component.name) continue;
      // Where the chain enters: the step's InPort, or the port a connection from the step before feeds.
      std::string in = port_of(chain.path[i]);
      for (const auto& c : connections) {
        if (!in.empty()) break;
        const bool from_before = i == 1 ? c.from == chain.path[0] : component_of(c.from) == component_of(chain.path[i - 1]);
        if (from_before && component_of(c.to) == component.name) in = port_of(c.to);
      }
      // Where it leaves: the OutPort a connection takes to the next step (to its InPort, if named).
      std::string leaves;
      for (const auto& c : connections) {
        const std::string& next = chain.path[i + 1];
        const bool to_next = port_of(next).empty() ? component_of(c.to) == component_of(next) : c.to == next;
        if (leaves.empty() && component_of(c.from) == component.name && to_next) leaves = port_of(c.from);
      }
      if (!in.empty() && !leaves.empty()) add(leaves, in);
    }
  }
  return out;
}

std::vector<std::string> SystemFile::arguments(const Component& component) const {
  std::vector<std::string> out = component.arguments();
  for (const auto& [port, ins] : stamp_derivations(component)) {
    std::string text = port + "=";
    for (std::size_t i = 0; i < ins.size(); ++i) text += (i ? "+" : "") + ins[i];
    out.insert(out.end(), {"--stamp-from", text});
  }
  for (const auto& chain : chains) {
    const std::string& last = chain.path.back();
    if (chain.path.size() < 2 || port_of(last).empty() || component_of(last) != component.name) continue;
    out.insert(out.end(), {"--watch-chain", fmt::format("{}:{}:{}ns:{}ns:{}", chain.name, port_of(last),
                                                        chain.deadline_ns, chain.max_age_ns,
                                                        rtm::miss_action_name(chain.on_miss))});
  }
  return out;
}

std::vector<std::string> SystemFile::parameter_set_names() const {
  std::set<std::string> names;
  for (const auto& c : components)
    for (const auto& [name, ignored] : c.parameter_sets) names.insert(name);
  return {names.begin(), names.end()};
}

rtm::Diagram SystemFile::diagram() const {
  rtm::Diagram d{.name = name};
  for (const auto& c : components) d.members.push_back({c.name});
  for (const auto& c : connections) d.connections.push_back({rtm::PortRef::parse(c.from), rtm::PortRef::parse(c.to), c.policy});
  return d;
}

std::filesystem::path find_program(const std::string& program, const std::filesystem::path& base) {
  namespace fs = std::filesystem;
  auto executable = [](const fs::path& p) {
    std::error_code ec;
    return fs::is_regular_file(p, ec) && ::access(p.c_str(), X_OK) == 0;
  };
  if (program.find('/') != std::string::npos) {
    fs::path p = fs::path(program).is_absolute() ? fs::path(program) : base / program;
    if (executable(p)) return p;
    throw SystemFileError(fmt::format("program {} not found or not executable", p.string()));
  }
  std::string searched;
  for (const char* var : {"RTM_BIN_PATH", "PATH"}) {
    const char* value = std::getenv(var);
    if (!value) continue;
    std::stringstream dirs(value);
    for (std::string dir; std::getline(dirs, dir, ':');) {
      if (dir.empty()) continue;
      if (executable(fs::path(dir) / program)) return fs::path(dir) / program;
    }
    searched += fmt::format("{}${}", searched.empty() ? "" : " and ", var);
  }
  throw SystemFileError(fmt::format("program '{}' not found in {} (set RTM_BIN_PATH to the "
                                    "folder of the component executables)",
                                    program, searched.empty() ? "an empty search path" : searched));
}

std::string SystemFile::to_yaml() const {
  YAML::Emitter out;
  out << YAML::BeginMap << YAML::Key << "name" << YAML::Value << name;
  if (naming) out << YAML::Key << "naming" << YAML::Value << *naming;
  out << YAML::Key << "components" << YAML::Value << YAML::BeginSeq;
  for (const auto& c : components) {
    out << YAML::BeginMap << YAML::Key << "name" << YAML::Value << c.name << YAML::Key << "command" << YAML::Value
        << YAML::Flow << c.command;
    if (!c.host.empty()) out << YAML::Key << "host" << YAML::Value << c.host;
    const auto write = [&](const Component::Parameters& parameters) {
      out << YAML::BeginMap;
      for (const auto& [name, value] : parameters) out << YAML::Key << name << YAML::Value << value;
      out << YAML::EndMap;
    };
    if (!c.parameters.empty()) {
      out << YAML::Key << "parameters" << YAML::Value;
      write(c.parameters);
    }
    if (!c.contract.empty()) {
      out << YAML::Key << "contract" << YAML::Value << YAML::Flow << YAML::BeginMap;
      for (const auto& [key, text] : c.contract) out << YAML::Key << key << YAML::Value << text;
      out << YAML::EndMap;
    }
    if (!c.parameter_sets.empty()) {
      out << YAML::Key << "parameter_sets" << YAML::Value << YAML::BeginMap;
      for (const auto& [set, parameters] : c.parameter_sets) {
        out << YAML::Key << set << YAML::Value;
        write(parameters);
      }
      out << YAML::EndMap;
    }
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  if (!connections.empty()) {
    out << YAML::Key << "connections" << YAML::Value << YAML::BeginSeq;
    for (const auto& c : connections) {
      out << YAML::Flow << YAML::BeginMap << YAML::Key << "from" << YAML::Value << c.from << YAML::Key << "to"
          << YAML::Value << c.to;
      if (c.policy.once) out << YAML::Key << "type" << YAML::Value << "once";
      ConnPolicy rest = c.policy;
      rest.once = false;
      if (rest != ConnPolicy::repeated()) {
        // Without once/repeated: 'type' says that, as in files written by hand.
        const std::string text = to_string(rest);
        out << YAML::Key << "policy" << YAML::Value << text.substr(text.find(' ') + 1);
      }
      out << YAML::EndMap;
    }
    out << YAML::EndSeq;
  }
  if (!activate.empty()) out << YAML::Key << "activate" << YAML::Value << YAML::Flow << activate;
  if (!chains.empty()) {
    out << YAML::Key << "chains" << YAML::Value << YAML::BeginSeq;
    for (const auto& c : chains) {
      out << YAML::Flow << YAML::BeginMap << YAML::Key << "name" << YAML::Value << c.name << YAML::Key << "path"
          << YAML::Value << YAML::Flow << c.path;
      if (c.deadline_ns > 0) out << YAML::Key << "deadline" << YAML::Value << std::to_string(c.deadline_ns) + "ns";
      if (c.max_age_ns > 0) out << YAML::Key << "max_age" << YAML::Value << std::to_string(c.max_age_ns) + "ns";
      if (c.on_miss != rtm::MissAction::count) out << YAML::Key << "on_miss" << YAML::Value << rtm::miss_action_name(c.on_miss);
      out << YAML::EndMap;
    }
    out << YAML::EndSeq;
  }
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

}  // namespace rtm::cli
