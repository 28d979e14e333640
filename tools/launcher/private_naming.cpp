// SPDX-License-Identifier: Apache-2.0
#include "launcher/private_naming.h"

#include "process.h"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <arpa/inet.h>
#include <fcntl.h>
#include <sys/file.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace rtm::cli {
namespace fs = std::filesystem;
namespace {

fs::path names_folder() { return SystemState::directory() / "names"; }
fs::path state_file() { return names_folder() / "state.yaml"; }

// Held while one `rtm names` looks at, starts or stops the service: two at once would start
// two, and the one recorded last would leave the other running unrecorded.
class NamesLock {
 public:
  NamesLock() : fd_(::open((SystemState::directory() / "names.lock").c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0600)) {
    if (fd_ < 0) throw std::runtime_error(fmt::format("rtm names: cannot open its lock: {}", std::strerror(errno)));
    while (::flock(fd_, LOCK_EX) != 0) {
      if (errno != EINTR) {
        ::close(fd_);
        throw std::runtime_error(fmt::format("rtm names: cannot take its lock: {}", std::strerror(errno)));
      }
    }
  }
  ~NamesLock() { ::close(fd_); }  // closing releases the lock
  NamesLock(const NamesLock&) = delete;
  NamesLock& operator=(const NamesLock&) = delete;

 private:
  int fd_;
};

// A loopback address of port, to connect() or bind().
sockaddr_in loopback(std::uint16_t port) {
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = htons(port);
  return address;
}

// A port on 127.0.0.1 nothing listens on now (the kernel's choice).
std::uint16_t free_loopback_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw std::runtime_error("rtm names: no socket for a free port");
  sockaddr_in address = loopback(0);
  socklen_t length = sizeof address;
  const bool ok = ::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0 &&
                  ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) == 0;
  ::close(fd);
  if (!ok) throw std::runtime_error("rtm names: no free port on 127.0.0.1");
  return ntohs(address.sin_port);
}

bool accepts(std::uint16_t port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return false;
  const sockaddr_in address = loopback(port);
  const bool ok = ::connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0;
  ::close(fd);
  return ok;
}

// The recorded service, whether or not it still runs; nullopt when none is recorded or the
// record is unreadable (the next start writes a new one).
std::optional<PrivateNaming> recorded() {
  std::error_code error;
  if (!fs::is_regular_file(state_file(), error)) return std::nullopt;
  try {
    const YAML::Node node = YAML::LoadFile(state_file().string());
    PrivateNaming n{NamingAddress::parse(node["address"].as<std::string>()),
                    {"omniNames", node["pid"].as<pid_t>(), node["start_time"].as<unsigned long long>(),
                     names_folder() / "omniNames.log"},
                    false};
    if (n.process.pid <= 0) return std::nullopt;
    return n;
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

void record(const PrivateNaming& n) {
  YAML::Emitter out;
  out << YAML::BeginMap << YAML::Key << "address" << YAML::Value << n.address.to_string() << YAML::Key << "pid"
      << YAML::Value << n.process.pid << YAML::Key << "start_time" << YAML::Value << n.process.start_time
      << YAML::EndMap;
  const fs::path written = state_file().string() + ".new";
  std::ofstream(written) << out.c_str() << "\n";
  fs::rename(written, state_file());  // whole or not at all
}

// Starts omniNames on port with an empty data folder; the process once it accepts there,
// nullopt (and why into *why) when it exits or does not answer in time.
std::optional<LaunchedProcess> start_on(const fs::path& program, std::uint16_t port, std::chrono::milliseconds timeout,
                                        std::string* why) {
  const fs::path data = names_folder() / "data";
  fs::remove_all(data);  // omniNames -start refuses a folder holding its log
  fs::create_directories(data);
  LaunchedProcess p{"omniNames", 0, 0, names_folder() / "omniNames.log"};
  p.pid = spawn_detached({program.string(), "-start", std::to_string(port), "-logdir", data.string(), "-ignoreport",
                          "-ORBendPoint", fmt::format("giop:tcp:127.0.0.1:{}", port)},
                         p.log);
  p.start_time = proc_stat(p.pid).second;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline && process_alive(p)) {
    if (accepts(port) && process_alive(p)) return p;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  *why = fmt::format("on port {}: {}{}", port, process_alive(p) ? "no answer in time" : "it exited", log_tail(p.log, 5));
  stop_processes({p}, std::chrono::seconds(1), nullptr);
  return std::nullopt;
}

}  // namespace

std::optional<PrivateNaming> private_naming_running() {
  auto n = recorded();
  if (!n || !process_alive(n->process)) return std::nullopt;
  return n;
}

PrivateNaming private_naming_up(std::chrono::milliseconds timeout) {
  const NamesLock lock;
  if (auto running = private_naming_running()) return *running;
  fs::remove_all(names_folder());  // what a service gone since left behind
  fs::create_directories(names_folder());
  fs::path program;
  try {
    program = find_program("omniNames", names_folder());
  } catch (const SystemFileError&) {
    throw std::runtime_error("rtm names: omniNames is not in $PATH (Debian: apt-get install omniorb-nameserver)");
  }
  std::string why;
  for (int attempt = 0; attempt < 3; ++attempt) {  // another program may take a free port first
    const std::uint16_t port = free_loopback_port();
    if (auto process = start_on(program, port, timeout, &why)) {
      PrivateNaming n{NamingAddress::parse(fmt::format("127.0.0.1:{}", port)), *process, true};
      record(n);
      return n;
    }
  }
  throw std::runtime_error(fmt::format("rtm names: omniNames did not come up {}", why));
}

std::optional<PrivateNaming> private_naming_down(std::chrono::milliseconds grace) {
  const NamesLock lock;
  auto n = recorded();
  std::optional<PrivateNaming> stopped;
  if (n && process_alive(n->process)) {
    stop_processes({n->process}, grace, nullptr);
    stopped = n;
  }
  fs::remove_all(names_folder());
  return stopped;
}

}  // namespace rtm::cli
