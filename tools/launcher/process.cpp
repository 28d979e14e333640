// SPDX-License-Identifier: Apache-2.0
#include "process.h"

#include <fmt/format.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

namespace rtm::cli {
namespace fs = std::filesystem;

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
    dprintf(STDERR_FILENO, "rtm: exec %s: %s\n", args[0], std::strerror(errno));
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


bool process_alive(const LaunchedProcess& p) {
  auto [state, start] = proc_stat(p.pid);
  if (state == '\0' || state == 'X' || start != p.start_time) return false;
  if (state != 'Z') return true;
  // A zombie leader whose other threads are still exiting: the process still holds its files
  // (a listening socket) until the last of them is gone.
  std::error_code error;
  std::size_t threads = 0;
  for (fs::directory_iterator it(fmt::format("/proc/{}/task", p.pid), error), end; !error && it != end;
       it.increment(error))
    ++threads;
  return threads > 1;
}

}  // namespace rtm::cli
