// SPDX-License-Identifier: Apache-2.0
#include "rtm_test/child_process.h"

#include <fmt/format.h>
#include <fcntl.h>
#include <linux/close_range.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <stdexcept>

extern char** environ;

namespace rtm_test {

namespace {

// Resolved before fork: between fork and exec only async-signal-safe calls are allowed.
std::string find_program(const std::string& name) {
  if (name.find('/') != std::string::npos) return name;
  const char* path = std::getenv("PATH");
  std::string_view dirs = path != nullptr ? path : "/usr/bin:/bin";
  while (!dirs.empty()) {
    const auto colon = dirs.find(':');
    const auto dir = dirs.substr(0, colon);
    const auto candidate = std::filesystem::path(dir) / name;
    if (::access(candidate.c_str(), X_OK) == 0) return candidate.string();
    if (colon == std::string_view::npos) break;
    dirs.remove_prefix(colon + 1);
  }
  throw std::runtime_error(fmt::format("cannot start '{}': not found in PATH", name));
}

std::vector<std::string> environment_with(const std::vector<std::string>& extra) {
  std::vector<std::string> env;
  for (char** entry = environ; *entry != nullptr; ++entry) {
    const std::string_view item(*entry);
    const auto key = item.substr(0, item.find('=') + 1);
    bool replaced = false;
    for (const auto& override_entry : extra) {
      if (override_entry.starts_with(key)) replaced = true;
    }
    if (!replaced) env.emplace_back(item);
  }
  env.insert(env.end(), extra.begin(), extra.end());
  return env;
}

std::vector<char*> c_strings(std::vector<std::string>& strings) {
  std::vector<char*> pointers;
  for (auto& s : strings) pointers.push_back(s.data());
  pointers.push_back(nullptr);
  return pointers;
}

ExitStatus decode(int status) {
  if (WIFEXITED(status)) return ExitStatus{true, WEXITSTATUS(status), 0};
  return ExitStatus{false, 0, WIFSIGNALED(status) ? WTERMSIG(status) : 0};
}

}  // namespace

std::string ExitStatus::to_string() const {
  if (exited) return fmt::format("exit {}", code);
  return fmt::format("signal {} ({})", signal, ::strsignal(signal));
}

ChildProcess::ChildProcess(std::vector<std::string> argv) : ChildProcess(std::move(argv), Options{}) {}

ChildProcess::ChildProcess(std::vector<std::string> argv, Options options)
    : argv_(std::move(argv)), options_(std::move(options)) {
  if (argv_.empty()) throw std::invalid_argument("ChildProcess: empty argv");
  std::string path = find_program(argv_.front());
  auto env_strings = environment_with(options_.extra_env);
  auto args = c_strings(argv_);
  auto env = c_strings(env_strings);

  int pipe_fds[2];
  if (::pipe2(pipe_fds, O_CLOEXEC) != 0) {
    throw std::runtime_error(fmt::format("cannot start '{}': pipe: {}", path, std::strerror(errno)));
  }
  const pid_t parent = ::getpid();
  pid_ = ::fork();
  if (pid_ < 0) {
    const int error = errno;
    ::close(pipe_fds[0]);
    ::close(pipe_fds[1]);
    throw std::runtime_error(fmt::format("cannot start '{}': fork: {}", path, std::strerror(error)));
  }
  if (pid_ == 0) {
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(127);
    ::dup2(pipe_fds[1], STDOUT_FILENO);
    ::dup2(pipe_fds[1], STDERR_FILENO);
    // Sockets and pipes of the test process (and of other children) must not leak in.
    ::syscall(SYS_close_range, 3U, ~0U, CLOSE_RANGE_CLOEXEC);
    sigset_t none;
    sigemptyset(&none);
    ::sigprocmask(SIG_SETMASK, &none, nullptr);
    ::execve(path.c_str(), args.data(), env.data());
    constexpr char kFailed[] = "ChildProcess: execve failed\n";
    [[maybe_unused]] auto ignored = ::write(STDERR_FILENO, kFailed, sizeof(kFailed) - 1);
    ::_exit(127);
  }
  ::close(pipe_fds[1]);
  reader_ = std::thread([this, fd = pipe_fds[0]] { read_output(fd); });
}

ChildProcess::~ChildProcess() {
  try {
    stop();
  } catch (...) {
    // A destructor must not throw; the child is reaped by stop() in every path that returns.
  }
  if (reader_.joinable()) reader_.join();
}

void ChildProcess::read_output(int fd) {
  const auto name = std::filesystem::path(argv_.front()).filename().string();
  std::string pending;
  char buffer[4096];
  for (;;) {
    const ssize_t n = ::read(fd, buffer, sizeof(buffer));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    pending.append(buffer, static_cast<std::size_t>(n));
    std::size_t newline;
    while ((newline = pending.find('\n')) != std::string::npos) {
      std::string line = pending.substr(0, newline);
      pending.erase(0, newline + 1);
      if (options_.echo_output) std::fprintf(stderr, "[%s %d] %s\n", name.c_str(), pid_, line.c_str());
      std::lock_guard lock(mutex_);
      lines_.push_back(std::move(line));
      line_added_.notify_all();
    }
  }
  ::close(fd);
  std::lock_guard lock(mutex_);
  if (!pending.empty()) lines_.push_back(std::move(pending));
  output_closed_ = true;
  line_added_.notify_all();
}

std::string ChildProcess::wait_for_line(std::string_view text, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  std::unique_lock lock(mutex_);
  std::size_t checked = 0;
  for (;;) {
    for (; checked < lines_.size(); ++checked) {
      if (lines_[checked].find(text) != std::string::npos) return lines_[checked];
    }
    if (output_closed_) {
      lock.unlock();
      throw std::runtime_error(fmt::format("{} ended before printing '{}'; output:\n{}", program(),
                                           text, output()));
    }
    if (line_added_.wait_until(lock, deadline) == std::cv_status::timeout && checked == lines_.size()) {
      lock.unlock();
      throw std::runtime_error(fmt::format("{} did not print '{}' within {} ms; output:\n{}", program(),
                                           text, timeout.count(), output()));
    }
  }
}

std::string ChildProcess::wait_until_bound(std::chrono::milliseconds timeout) {
  return wait_for_line("bound ", timeout);
}

std::size_t ChildProcess::count_lines(std::string_view text) const {
  std::lock_guard lock(mutex_);
  std::size_t count = 0;
  for (const auto& line : lines_) count += line.find(text) != std::string::npos ? 1 : 0;
  return count;
}

std::string ChildProcess::output() const {
  std::lock_guard lock(mutex_);
  std::string all;
  for (const auto& line : lines_) (all += line) += '\n';
  return all;
}

void ChildProcess::send_signal(int signal_number) {
  if (!status_) ::kill(pid_, signal_number);
}

std::optional<ExitStatus> ChildProcess::wait_for_exit(std::chrono::milliseconds timeout) {
  if (status_) return status_;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    int status = 0;
    const pid_t result = ::waitpid(pid_, &status, WNOHANG);
    if (result == pid_) {
      status_ = decode(status);
      await_output_end();
      return status_;
    }
    if (result < 0 && errno != EINTR) {
      throw std::runtime_error(fmt::format("waitpid({}) for {}: {}", pid_, program(), std::strerror(errno)));
    }
    if (std::chrono::steady_clock::now() >= deadline) return std::nullopt;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
}

bool ChildProcess::running() { return !wait_for_exit(std::chrono::milliseconds(0)).has_value(); }

ExitStatus ChildProcess::stop() {
  if (status_) return *status_;
  ::kill(pid_, SIGTERM);
  if (auto status = wait_for_exit(options_.stop_grace)) return *status;
  return kill_now();
}

ExitStatus ChildProcess::kill_now() {
  if (status_) return *status_;
  ::kill(pid_, SIGKILL);
  int status = 0;
  while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
  }
  status_ = decode(status);
  await_output_end();
  return *status_;
}

void ChildProcess::await_output_end() {
  // The reader may not have read the last lines when waitpid reports the exit; a caller that
  // saw the exit must also see everything printed before it. Bounded: a grandchild that
  // inherited the pipe may keep it open.
  std::unique_lock lock(mutex_);
  line_added_.wait_for(lock, std::chrono::seconds(2), [this] { return output_closed_; });
}

}  // namespace rtm_test
