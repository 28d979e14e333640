// SPDX-License-Identifier: Apache-2.0
#include "launcher/running_system.h"

#include "rtm/naming.h"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <optional>
#include <stdexcept>
#include <system_error>
#include <utility>

namespace rtm::cli {
namespace {

// How a component was started, as a system file says it: its command and, for a member of
// rtm-container, its host.
struct StartedAs {
  std::vector<std::string> command;
  std::string host;
};

// A member of rtm-container: the container's --name is the host; the member's group (after
// a --: its name, its program, its options) is its command.
StartedAs member_of_container(const std::vector<std::string>& args, const std::string& member) {
  StartedAs started;
  std::size_t i = 1;
  for (; i < args.size() && args[i] != "--"; ++i)
    if (args[i] == "--name" && i + 1 < args.size()) started.host = args[++i];
  while (i < args.size()) {
    const std::size_t begin = i + 1;
    std::size_t end = begin;
    while (end < args.size() && args[end] != "--") ++end;
    if (end - begin >= 2 && args[begin] == member) {
      for (std::size_t k = begin + 1; k < end; ++k)
        if (args[k] != "--on") started.command.push_back(args[k]);
      return started;
    }
    i = end;
  }
  return {};
}

// How process pid started component `name`, as a system file's command: the program by its
// absolute path (/proc/<pid>/exe), then its arguments without those `rtm up` adds itself
// (--name, --naming) and without --on (the file's activate list says that); a member of
// rtm-container by its own group and the container's name as its host. Empty when the process
// is not readable from here.
StartedAs command_of(long pid, const std::string& name) {
  std::error_code error;
  const auto exe = std::filesystem::read_symlink(fmt::format("/proc/{}/exe", pid), error);
  if (error) return {};
  std::ifstream in(fmt::format("/proc/{}/cmdline", pid), std::ios::binary);
  std::vector<std::string> args;
  for (std::string arg; std::getline(in, arg, '\0');) args.push_back(arg);
  if (args.empty()) return {};
  if (exe.filename() == "rtm-container") return member_of_container(args, name);
  std::vector<std::string> command{exe.string()};
  for (std::size_t i = 1; i < args.size(); ++i) {
    const std::string& a = args[i];
    if ((a == "--name" || a == "--naming") && i + 1 < args.size()) {
      ++i;
      continue;
    }
    if (a == "--on" || a.rfind("--name=", 0) == 0 || a.rfind("--naming=", 0) == 0) continue;
    command.push_back(a);
  }
  return {command, {}};
}

std::optional<long> pid_of(const ComponentInfo& c) {
  for (const auto& s : c.statistics)
    if (s.name == "pid" && s.value > 0) return static_cast<long>(s.value);
  return std::nullopt;
}

}  // namespace

bool is_tool_subscriber(std::string_view peer) {
  return std::any_of(kToolSubscriberPrefixes.begin(), kToolSubscriberPrefixes.end(),
                     [&](std::string_view prefix) { return peer.starts_with(prefix); });
}

bool follows_naming_rule(const std::string& name) {
  try {
    check_name(name);
    return true;
  } catch (const std::invalid_argument&) {
    return false;
  }
}

SystemFile running_system(const Browser& browser, const std::string& name, std::vector<LeftOut>& left_out) {
  SystemFile file;
  file.name = name.empty() ? "saved" : name;
  check_name(file.name);
  const std::string here = ComponentPath::on_this_host("x").host;
  for (const auto& c : browser.list("", true)) {
    if (c.liveness != Liveness::alive) continue;
    if (!follows_naming_rule(c.path.name)) {
      left_out.push_back({c.path.name, "not a valid name: bound by hand, not an RTM component"});
      continue;
    }
    const auto pid = pid_of(c);
    StartedAs started = (pid && c.path.host == here) ? command_of(*pid, c.path.name) : StartedAs{};
    if (started.command.empty()) {
      left_out.push_back({c.path.name, "its command cannot be read from this host"});
      continue;
    }
    SystemFile::Component saved{c.path.name, std::move(started.command), {}, {}};
    saved.host = std::move(started.host);
    for (const auto& p : c.parameters)
      if (p.access != "fixed") saved.parameters.emplace_back(p.name, p.value);
    file.components.push_back(std::move(saved));
    if (c.state == "on") file.activate.push_back(c.path.name);
    for (const auto& p : c.ports)
      for (const auto& s : p.subscriptions)
        if (!is_tool_subscriber(s.peer))  // a tool's InPort (a plot, a watch, a recording), not the system's wiring
          file.connections.push_back({c.path.name + "." + p.name, s.peer,
                                    s.asked ? *s.asked : s.req_type == "once" ? ConnPolicy::one_shot() : ConnPolicy::repeated()});
  }
  return file;
}

}  // namespace rtm::cli
