// SPDX-License-Identifier: Apache-2.0
#include "launcher/launcher.h"

#include "launcher/timing_check.h"

#include "process.h"

#include "host/access.h"
#include "host/socket_peer.h"
#include "rtm/data.h"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <thread>

namespace rtm::cli {
namespace fs = std::filesystem;


fs::path SystemState::directory() {
  const char* runtime = std::getenv("XDG_RUNTIME_DIR");
  fs::path dir = runtime && *runtime ? fs::path(runtime) / "rtm"
                                     : fs::path(fmt::format("/tmp/rtm-{}", ::getuid()));
  // It holds the pids `rtm down` stops: this user's alone. A folder another user made first
  // (in /tmp, say), or a link, is refused; one of this user's open to others is closed.
  if (::mkdir(dir.c_str(), 0700) != 0 && errno != EEXIST)
    throw std::runtime_error(fmt::format("cannot make {}: {}", dir.string(), std::strerror(errno)));
  struct stat st {};
  if (::lstat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode) || st.st_uid != ::getuid())
    throw std::runtime_error(fmt::format("{} is not a folder of this user's (a link, or another user's): rtm keeps "
                                         "the pids it may stop there and will not use it",
                                         dir.string()));
  if ((st.st_mode & 077) != 0 && ::chmod(dir.c_str(), 0700) != 0)
    throw std::runtime_error(fmt::format("cannot close {} to other users: {}", dir.string(), std::strerror(errno)));
  return dir;
}

fs::path SystemState::path_for(const std::string& system) {
  return directory() / (system + ".state.yaml");
}

void SystemState::save() const {
  YAML::Emitter out;
  out << YAML::BeginMap << YAML::Key << "system" << YAML::Value << system << YAML::Key << "naming"
      << YAML::Value << naming << YAML::Key << "file" << YAML::Value << file.string()
      << YAML::Key << "processes" << YAML::Value << YAML::BeginSeq;
  for (const auto& p : processes) {
    out << YAML::Flow << YAML::BeginMap << YAML::Key << "name" << YAML::Value << p.name
        << YAML::Key << "pid" << YAML::Value << p.pid << YAML::Key << "start" << YAML::Value
        << p.start_time << YAML::Key << "log" << YAML::Value << p.log.string() << YAML::Key << "members"
        << YAML::Value << YAML::Flow << p.members << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::Key << "connections" << YAML::Value << YAML::BeginSeq;
  for (const auto& c : connections) {
    out << YAML::Flow << YAML::BeginMap << YAML::Key << "from" << YAML::Value << c.from
        << YAML::Key << "to" << YAML::Value << c.to << YAML::Key << "policy" << YAML::Value
        << to_string(c.policy) << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::Key << "activated" << YAML::Value << YAML::Flow << activated
      << YAML::EndMap;
  // Written whole or not at all: a temporary file, flushed to disk, then renamed over the old
  // state. A write that fails (a full disk) is an error, never an empty state file: `rtm down`
  // needs it to find the processes.
  const fs::path target = path_for(system);
  const fs::path tmp = target.string() + ".tmp";
  const std::string text = std::string(out.c_str()) + "\n";
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  int error = fd < 0 ? errno : 0;
  if (fd >= 0) {
    std::size_t written = 0;
    while (error == 0 && written < text.size()) {
      const ssize_t n = ::write(fd, text.data() + written, text.size() - written);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) error = n < 0 ? errno : EIO;
      else written += static_cast<std::size_t>(n);
    }
    if (error == 0 && ::fsync(fd) != 0) error = errno;
    if (::close(fd) != 0 && error == 0) error = errno;
  }
  if (error == 0 && ::rename(tmp.c_str(), target.c_str()) != 0) error = errno;
  if (error != 0) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw SystemFileError(fmt::format("cannot write the state of system '{}' to {}: {}", system, target.string(),
                                      std::strerror(error)));
  }
}

SystemState SystemState::load(const std::string& system) {
  const fs::path p = path_for(system);
  if (!fs::exists(p)) {
    throw SystemFileError(fmt::format("no running system '{}' (no state at {}): is it up?",
                                      system, p.string()));
  }
  SystemState s;
  try {
    YAML::Node root = YAML::LoadFile(p.string());
    s.system = root["system"].as<std::string>();
    s.naming = root["naming"].as<std::string>();
    s.file = root["file"].as<std::string>();
    for (const auto& n : root["processes"]) {
      LaunchedProcess p{n["name"].as<std::string>(), n["pid"].as<pid_t>(), n["start"].as<unsigned long long>(),
                        n["log"].as<std::string>()};
      // No members in the state files of older builds: a process was one component.
      p.members = n["members"] ? n["members"].as<std::vector<std::string>>() : std::vector<std::string>{p.name};
      s.processes.push_back(std::move(p));
    }
    for (const auto& n : root["connections"]) {
      // "type" in the state files of older builds; a whole policy since.
      ConnPolicy policy = n["policy"] ? parse_conn_policy(n["policy"].as<std::string>())
                          : n["type"].as<std::string>() == "once" ? ConnPolicy::one_shot()
                                                                  : ConnPolicy::repeated();
      s.connections.push_back({n["from"].as<std::string>(), n["to"].as<std::string>(), policy});
    }
    for (const auto& n : root["activated"]) s.activated.push_back(n.as<std::string>());
  } catch (const YAML::Exception& e) {
    throw SystemFileError(fmt::format("{}: damaged state file: {}", p.string(), e.msg));
  } catch (const std::invalid_argument& e) {
    throw SystemFileError(fmt::format("{}: damaged state file: {}", p.string(), e.what()));
  }
  return s;
}

// How messages name component `member` of p: "a" alone, "a (host h)" in a host's process.
std::string who(const LaunchedProcess& p, const std::string& member) {
  return member == p.name ? member : fmt::format("{} (host {})", member, p.name);
}

// The name must be bound to the process we started, not to another system's component of the
// same name nor to an object someone else bound there. Which process serves it is what the
// kernel says of its giop:unix: socket (SO_PEERCRED, host/access.h), never what the object
// says of itself.
void check_bound_to(const Browser& browser, const std::string& host, const LaunchedProcess& p,
                    const std::string& member) {
  RTM::RtComponent_var component = browser.component(host + "/" + member);
  const std::optional<rtm::Peer> peer = rtm::peer_of(component.in());
  if (peer && peer->pid && *peer->pid == p.pid) return;  // over giop:unix:
  if (peer && peer->socket_inode && rtm::process_holds_socket(p.pid, *peer->socket_inode)) return;  // TCP
  if (peer && peer->pid)
    throw BrowseError(fmt::format("{} is bound to another process (pid {}), not to the one rtm up started (pid {}): "
                                  "another system uses that name",
                                  who(p, member), *peer->pid, p.pid));
  throw BrowseError(fmt::format("{} is bound to another process, not to the one rtm up started (pid {}): the "
                                "kernel shows that process no socket of the connection to it ({}); another system "
                                "uses that name",
                                who(p, member), p.pid, peer ? peer->address : std::string("an object in rtm itself")));
}

// Until `member`'s name is bound to `p` itself (check_bound_to); throws when p exits first, when
// bind_timeout passes, or (check_interrupt) on Ctrl-C.
void wait_until_bound(const Browser& browser, const std::string& host, const LaunchedProcess& p,
                      const std::string& member, std::chrono::milliseconds bind_timeout,
                      const std::function<void()>& check_interrupt) {
  const auto deadline = std::chrono::steady_clock::now() + bind_timeout;
  while (!browser.naming().is_bound(ComponentPath{host, member})) {
    check_interrupt();
    if (!process_alive(p))
      throw BrowseError(fmt::format("{} exited before it was bound; its log:{}", who(p, member), log_tail(p.log, 10)));
    if (std::chrono::steady_clock::now() > deadline) {
      throw BrowseError(fmt::format("{} was not bound in the naming service within {} ms; its log:{}", who(p, member),
                                    bind_timeout.count(), log_tail(p.log, 10)));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  check_bound_to(browser, host, p, member);
}

// A system whose recorded processes still run is up: it must go down first.
void refuse_if_up(const std::string& system) {
  if (!fs::exists(SystemState::path_for(system))) return;
  const SystemState old = SystemState::load(system);
  for (const auto& p : old.processes) {
    if (process_alive(p)) {
      throw SystemFileError(fmt::format("system '{}' is already up ({} runs as pid {}); `rtm down {}` first", system,
                                        p.name, p.pid, system));
    }
  }
}

namespace {

// The file's diagram against the ports of the running components, before anything is
// connected: every problem at once, each naming both ends.
void check_wiring(const SystemFile& file, const Browser& browser) {
  rtm::PortCatalogue ports{
      .find = [&browser](const rtm::PortRef& ref, bool in) -> std::optional<rtm::PortShape> {
        try {
          const ResolvedPort p = browser.port({ref.member, ref.port});
          if ((p.direction == Direction::in) != in) return std::nullopt;
          return rtm::PortShape{in, rtm::type_name(p.type.in()), p.elements.empty() ? std::vector<std::string>{} : p.units()};
        } catch (const BrowseError&) {
          return std::nullopt;
        }
      },
      .names = [&browser](const std::string& member, bool in) {
        std::vector<std::string> names;
        try {
          for (const auto& p : browser.describe(member).ports) {
            if ((p.direction == Direction::in) == in) names.push_back(p.name);
          }
        } catch (const BrowseError&) {
        }
        return names;
      },
  };
  try {
    file.diagram().check(ports);
  } catch (const rtm::DiagramError& e) {
    throw SystemFileError(fmt::format("{}: the wiring does not hold, nothing was connected: {}", file.path.string(),
                                      e.what()));
  }
}

}  // namespace

std::vector<ProcessToStart> processes_to_start(const SystemFile& file, const std::string& naming,
                                               const ProgramFinder& find) {
  const fs::path base = file.path.parent_path();
  std::vector<ProcessToStart> out;
  std::map<std::string, std::size_t> hosts;  // a host's process in out
  for (const auto& c : file.components) {
    if (c.host.empty()) {
      ProcessToStart p{c.name, file.arguments(c), {c.name}};
      p.command[0] = find(p.command[0], base).string();
      p.command.insert(p.command.end(), {"--name", c.name, "--naming", naming});
      out.push_back(std::move(p));
      continue;
    }
    auto [at, first] = hosts.try_emplace(c.host, out.size());
    if (first)
      out.push_back({c.host, {find("rtm-container", base).string(), "--name", c.host, "--naming", naming}, {}});
    ProcessToStart& p = out[at->second];
    // The program's path, so that rtm-container finds the module beside it
    // (<folder>/../lib/rtm/modules). A bare name no program answers to stays a name: the
    // container may still know its module ($RTM_MODULE_PATH, its own folder).
    const std::string& program = c.command[0];
    std::string resolved = program;
    try {
      resolved = fs::absolute(find(program, base)).string();
    } catch (const SystemFileError&) {
      if (program.find('/') != std::string::npos) throw;
    }
    p.command.insert(p.command.end(), {"--", c.name, resolved});
    const std::vector<std::string> arguments = file.arguments(c);
    p.command.insert(p.command.end(), std::next(arguments.begin()), arguments.end());
    p.members.push_back(c.name);
  }
  return out;
}

namespace {

// The file's contracts, checked before anything starts (only when it declares one: a file
// without any starts as before).
void check_contracts(const SystemFile& file, const LaunchOptions& options) {
  const bool declared = !file.chains.empty() || std::any_of(file.components.begin(), file.components.end(),
                                                            [](const auto& c) { return !c.contract.empty(); });
  if (!declared) return;
  const TimingCheck check = check_timing(file);
  std::string refusals;
  for (const auto& f : check.analysis.findings) {
    if (f.severity != TimingFinding::Severity::refusal) continue;
    refusals += fmt::format("\n  {}: {}", f.subject, f.text);
  }
  if (refusals.empty()) {
    if (options.progress) options.progress("timing contracts: the analysis says they hold (rtm check explains)");
    return;
  }
  if (!options.force)
    throw SystemFileError(fmt::format("{}: the system cannot keep its timing contracts:{}\n`rtm check {}` explains "
                                      "each bound; `rtm up --force` starts it anyway",
                                      file.path.string(), refusals, file.path.string()));
  if (options.progress)
    options.progress(fmt::format("WARNING: starting despite timing contracts it cannot keep (--force):{}", refusals));
}

}  // namespace

SystemState system_up(const SystemFile& file, const Browser& browser, const NamingAddress& naming,
                      const LaunchOptions& options) {
  auto say = [&](const std::string& line) {
    if (options.progress) options.progress(line);
  };
  auto check_interrupt = [&] {
    if (options.interrupted && options.interrupted())
      throw LaunchInterrupted(fmt::format("interrupted: stopped what `rtm up {}` had started", file.name));
  };
  refuse_if_up(file.name);
  if (!options.parameter_set.empty()) {
    const auto sets = file.parameter_set_names();
    if (std::find(sets.begin(), sets.end(), options.parameter_set) == sets.end()) {
      std::string known;
      for (const auto& s : sets) known += (known.empty() ? "" : ", ") + s;
      throw SystemFileError(fmt::format("{}: no component has the parameter set '{}' (sets: {})", file.path.string(),
                                        options.parameter_set, known.empty() ? "none" : known));
    }
  }
  check_contracts(file, options);
  SystemState state;
  state.system = file.name;
  state.naming = naming.to_string();
  state.file = file.path;
  const fs::path logs = SystemState::directory() / file.name;
  fs::create_directories(logs);
  try {
    // The naming service first, then every program, before starting any: a service that is
    // down or a typo starts nothing (is_bound throws only when the service cannot be reached).
    if (!file.components.empty()) browser.naming().is_bound({local_host_name(), file.components.front().name});
    const std::vector<ProcessToStart> starts = processes_to_start(file, naming.to_string());
    for (const auto& s : starts) {
      check_interrupt();
      LaunchedProcess p{s.name, 0, 0, logs / (s.name + ".log"), s.members};
      p.pid = spawn_detached(s.command, p.log);
      p.start_time = proc_stat(p.pid).second;
      state.processes.push_back(p);
      state.save();
      std::string what = p.name;
      if (p.members != std::vector<std::string>{p.name}) {
        what = fmt::format("host {} with", p.name);
        for (std::size_t i = 0; i < p.members.size(); ++i) what.append(i ? ", " : " ").append(p.members[i]);
      }
      say(fmt::format("started {} (pid {}, log {})", what, p.pid, p.log.string()));
    }
    const std::string host = local_host_name();
    for (const auto& p : state.processes) {
      for (const auto& member : p.members) {
        wait_until_bound(browser, host, p, member, options.bind_timeout, check_interrupt);
        say(fmt::format("bound {}", member));
      }
    }
    check_wiring(file, browser);
    for (const auto& c : file.components) {
      for (const auto& [parameter, value] : c.parameters_with(options.parameter_set)) {
        check_interrupt();
        const std::string now = browser.set_parameter(c.name, parameter, value);
        say(fmt::format("set {} {} = {}", c.name, parameter, now));
      }
    }
    for (const auto& c : file.connections) {
      check_interrupt();
      browser.connect(PortAddress::parse(c.from), PortAddress::parse(c.to), c.policy);
      state.connections.push_back(c);
      state.save();
      say(fmt::format("connected {} -> {}", c.from, c.to));
    }
    for (const auto& name : file.activate) {
      check_interrupt();
      browser.component(name)->on();
      state.activated.push_back(name);
      state.save();
      say(fmt::format("on {}", name));
    }
    check_interrupt();
  } catch (...) {
    system_down(state, &browser, options);
    throw;
  }
  return state;
}

std::vector<std::string> system_down(const SystemState& state, const Browser* browser,
                                     const LaunchOptions& options) {
  auto say = [&](const std::string& line) {
    if (options.progress) options.progress(line);
  };
  if (browser) {
    // Best effort: a component already gone is simply skipped.
    for (auto it = state.activated.rbegin(); it != state.activated.rend(); ++it) {
      try {
        browser->component(*it)->off();
        say(fmt::format("off {}", *it));
      } catch (const std::exception&) {
      } catch (const CORBA::Exception&) {
      }
    }
    for (auto it = state.connections.rbegin(); it != state.connections.rend(); ++it) {
      try {
        browser->disconnect(PortAddress::parse(it->from), PortAddress::parse(it->to),
                            it->policy.once ? RTM::once : RTM::repeated);
      } catch (const std::exception&) {
      } catch (const CORBA::Exception&) {
      }
    }
  }
  std::vector<std::string> killed;
  stop_processes(state.processes, options.stop_timeout, &killed);
  for (const auto& p : state.processes) say(fmt::format("stopped {}", p.name));
  // A process killed after its grace (one still starting up when the SIGTERM came, on a
  // loaded host) could not unbind its name: the binding, now dead, goes too. Only if dead:
  // a live component of that name is not ours.
  if (browser && !killed.empty()) {
    const std::string host = local_host_name();
    for (const auto& p : state.processes) {
      if (std::find(killed.begin(), killed.end(), p.name) == killed.end()) continue;
      for (const auto& name : p.members) {
        try {
          for (const auto& path : browser->clean(host + "/" + name))
            say(fmt::format("unbound {}/{}", path.host, path.name));
        } catch (const std::exception&) {
        } catch (const CORBA::Exception&) {
        }
      }
    }
  }
  std::error_code ec;
  fs::remove(SystemState::path_for(state.system), ec);
  return killed;
}

}  // namespace rtm::cli
