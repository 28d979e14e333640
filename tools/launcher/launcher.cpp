// SPDX-License-Identifier: Apache-2.0
#include "launcher/launcher.h"

#include "host/access.h"
#include "host/socket_peer.h"
#include "rtm/data.h"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <thread>

namespace rtm::cli {
namespace fs = std::filesystem;
namespace {

// /proc/<pid>/stat: state (field 3) and start time (field 22). Empty state when gone.
std::pair<char, unsigned long long> proc_stat(pid_t pid) {
  std::ifstream in(fmt::format("/proc/{}/stat", pid));
  std::string line;
  if (!in || !std::getline(in, line)) return {'\0', 0};
  auto close = line.rfind(')');  // the command name may hold spaces and ')'
  if (close == std::string::npos) return {'\0', 0};
  std::istringstream rest(line.substr(close + 2));
  char state = 0;
  rest >> state;
  std::string field;
  for (int i = 4; i < 22 && rest >> field; ++i) {
  }
  unsigned long long start = 0;
  rest >> start;
  return {state, start};
}

std::string log_tail(const fs::path& log, int lines) {
  std::ifstream in(log);
  std::vector<std::string> all;
  for (std::string l; std::getline(in, l);) all.push_back(l);
  std::string out;
  for (std::size_t i = all.size() > static_cast<std::size_t>(lines) ? all.size() - lines : 0;
       i < all.size(); ++i) {
    out += "\n    " + all[i];
  }
  return out;
}

// Starts argv detached: a grandchild in its own session, so the system outlives `rtm up` and
// is reaped by init. Returns its pid (read back through a pipe).
pid_t spawn_detached(const std::vector<std::string>& argv, const fs::path& log) {
  int pipe_fds[2];
  if (::pipe2(pipe_fds, O_CLOEXEC) != 0) throw std::runtime_error(std::strerror(errno));
  pid_t child = ::fork();
  if (child < 0) throw std::runtime_error(fmt::format("fork: {}", std::strerror(errno)));
  if (child == 0) {
    ::setsid();
    pid_t grandchild = ::fork();
    if (grandchild != 0) {
      (void)!::write(pipe_fds[1], &grandchild, sizeof grandchild);
      ::_exit(grandchild > 0 ? 0 : 1);
    }
    int out = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    int null = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
    if (out >= 0) {
      ::dup2(out, STDOUT_FILENO);
      ::dup2(out, STDERR_FILENO);
    }
    if (null >= 0) ::dup2(null, STDIN_FILENO);
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    ::execv(args[0], args.data());
    dprintf(STDERR_FILENO, "rtm up: exec %s: %s\n", args[0], std::strerror(errno));
    ::_exit(127);
  }
  ::close(pipe_fds[1]);
  pid_t pid = -1;
  ssize_t n = ::read(pipe_fds[0], &pid, sizeof pid);
  ::close(pipe_fds[0]);
  int status = 0;
  ::waitpid(child, &status, 0);
  if (n != sizeof pid || pid <= 0) throw std::runtime_error("could not start the process");
  return pid;
}

void stop_processes(const std::vector<LaunchedProcess>& procs, std::chrono::milliseconds grace,
                    std::vector<std::string>* killed) {
  for (auto it = procs.rbegin(); it != procs.rend(); ++it) {
    if (process_alive(*it)) ::kill(it->pid, SIGTERM);
  }
  auto deadline = std::chrono::steady_clock::now() + grace;
  auto any_alive = [&] {
    for (const auto& p : procs) {
      if (process_alive(p)) return true;
    }
    return false;
  };
  while (any_alive() && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  for (const auto& p : procs) {
    if (process_alive(p)) {
      ::kill(p.pid, SIGKILL);
      if (killed) killed->push_back(p.name);
    }
  }
  // A process in uninterruptible sleep ignores even SIGKILL for a while: bounded wait.
  const auto kill_deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  while (any_alive() && std::chrono::steady_clock::now() < kill_deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
}

}  // namespace

bool process_alive(const LaunchedProcess& p) {
  auto [state, start] = proc_stat(p.pid);
  return state != '\0' && state != 'Z' && state != 'X' && start == p.start_time;
}

fs::path SystemState::directory() {
  const char* runtime = std::getenv("XDG_RUNTIME_DIR");
  fs::path dir = runtime && *runtime ? fs::path(runtime) / "rtm"
                                     : fs::path(fmt::format("/tmp/rtm-{}", ::getuid()));
  fs::create_directories(dir);
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
        << p.start_time << YAML::Key << "log" << YAML::Value << p.log.string() << YAML::EndMap;
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
      s.processes.push_back({n["name"].as<std::string>(), n["pid"].as<pid_t>(),
                             n["start"].as<unsigned long long>(), n["log"].as<std::string>()});
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

// The name must be bound to the process we started, not to another system's component of the
// same name nor to an object someone else bound there. Which process serves it is what the
// kernel says of its giop:unix: socket (SO_PEERCRED, host/access.h), never what the object
// says of itself.
void check_bound_to(const Browser& browser, const std::string& host, const LaunchedProcess& p) {
  RTM::RtComponent_var component = browser.component(host + "/" + p.name);
  const std::optional<rtm::Peer> peer = rtm::peer_of(component.in());
  if (peer && peer->pid && *peer->pid == p.pid) return;  // over giop:unix:
  if (peer && peer->socket_inode && rtm::process_holds_socket(p.pid, *peer->socket_inode)) return;  // TCP
  if (peer && peer->pid)
    throw BrowseError(fmt::format("{} is bound to another process (pid {}), not to the one rtm up started (pid {}): "
                                  "another system uses that name",
                                  p.name, *peer->pid, p.pid));
  throw BrowseError(fmt::format("{} is bound to another process, not to the one rtm up started (pid {}): the "
                                "kernel shows that process no socket of the connection to it ({}); another system "
                                "uses that name",
                                p.name, p.pid, peer ? peer->address : std::string("an object in rtm itself")));
}

// Until `p`'s name is bound to `p` itself (check_bound_to); throws when p exits first, when
// bind_timeout passes, or (check_interrupt) on Ctrl-C.
void wait_until_bound(const Browser& browser, const std::string& host, const LaunchedProcess& p,
                      std::chrono::milliseconds bind_timeout, const std::function<void()>& check_interrupt) {
  const auto deadline = std::chrono::steady_clock::now() + bind_timeout;
  while (!browser.naming().is_bound(ComponentPath{host, p.name})) {
    check_interrupt();
    if (!process_alive(p))
      throw BrowseError(fmt::format("{} exited before it was bound; its log:{}", p.name, log_tail(p.log, 10)));
    if (std::chrono::steady_clock::now() > deadline) {
      throw BrowseError(fmt::format("{} was not bound in the naming service within {} ms; its log:{}", p.name,
                                    bind_timeout.count(), log_tail(p.log, 10)));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  check_bound_to(browser, host, p);
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
  SystemState state;
  state.system = file.name;
  state.naming = naming.to_string();
  state.file = file.path;
  const fs::path logs = SystemState::directory() / file.name;
  fs::create_directories(logs);
  try {
    // Resolve every program before starting any, so a typo starts nothing.
    std::vector<std::vector<std::string>> argvs;
    for (const auto& c : file.components) {
      std::vector<std::string> argv = c.command;
      argv[0] = find_program(argv[0], file.path.parent_path()).string();
      argv.insert(argv.end(), {"--name", c.name, "--naming", naming.to_string()});
      argvs.push_back(std::move(argv));
    }
    for (std::size_t i = 0; i < file.components.size(); ++i) {
      check_interrupt();
      const auto& c = file.components[i];
      LaunchedProcess p{c.name, 0, 0, logs / (c.name + ".log")};
      p.pid = spawn_detached(argvs[i], p.log);
      p.start_time = proc_stat(p.pid).second;
      state.processes.push_back(p);
      state.save();
      say(fmt::format("started {} (pid {}, log {})", c.name, p.pid, p.log.string()));
    }
    const std::string host = local_host_name();
    for (const auto& p : state.processes) {
      wait_until_bound(browser, host, p, options.bind_timeout, check_interrupt);
      say(fmt::format("bound {}", p.name));
    }
    check_wiring(file, browser);
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
    for (const auto& name : killed) {
      try {
        for (const auto& path : browser->clean(host + "/" + name)) say(fmt::format("unbound {}/{}", path.host, path.name));
      } catch (const std::exception&) {
      } catch (const CORBA::Exception&) {
      }
    }
  }
  std::error_code ec;
  fs::remove(SystemState::path_for(state.system), ec);
  return killed;
}

}  // namespace rtm::cli
