// SPDX-License-Identifier: Apache-2.0
// A child process that a test starts and that is always stopped and reaped, also when the
// test fails: the destructor sends SIGTERM, then SIGKILL after a grace period, and waits for
// it. The child also gets SIGKILL if the test process dies (PR_SET_PDEATHSIG), so no
// component outlives a crashed test. Its stdout and stderr are collected line by line.
#pragma once

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <sys/types.h>
#include <thread>
#include <vector>

namespace rtm_test {

struct ExitStatus {
  bool exited = false;  // ended by exit(); else killed by signal
  int code = 0;         // exit code when exited
  int signal = 0;       // terminating signal otherwise

  bool clean() const { return exited && code == 0; }
  std::string to_string() const;  // "exit 0", "signal 9 (Killed)"
};

class ChildProcess {
 public:
  struct Options {
    std::vector<std::string> extra_env;  // "NAME=value" added to (or replacing in) the environment
    std::chrono::milliseconds stop_grace{5000};  // SIGTERM -> SIGKILL
    bool echo_output = true;  // copy the child's lines to our stderr, prefixed with its name
  };

  // Starts argv[0] (a path, or a name looked up in PATH). Throws std::runtime_error naming the
  // program when it cannot be started.
  explicit ChildProcess(std::vector<std::string> argv);
  ChildProcess(std::vector<std::string> argv, Options options);
  ~ChildProcess();
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  pid_t pid() const { return pid_; }
  const std::string& program() const { return argv_.front(); }

  // Waits until an output line contains text and returns that line. Throws std::runtime_error
  // (with the output so far) on timeout or when the child exits first.
  std::string wait_for_line(std::string_view text,
                            std::chrono::milliseconds timeout = std::chrono::seconds(10));
  // Waits for the component runner's "bound <name> at ..." line.
  std::string wait_until_bound(std::chrono::milliseconds timeout = std::chrono::seconds(10));
  // Number of output lines so far that contain text.
  std::size_t count_lines(std::string_view text) const;
  // Everything the child printed so far.
  std::string output() const;

  void send_signal(int signal_number);
  // Exit status once the child has ended within timeout (and reaps it), else nullopt. Once it
  // returns a status, output() holds everything the child printed.
  std::optional<ExitStatus> wait_for_exit(std::chrono::milliseconds timeout);
  bool running();
  // SIGTERM, then SIGKILL after the grace period; reaps. Idempotent.
  ExitStatus stop();
  // SIGKILL at once; reaps.
  ExitStatus kill_now();

 private:
  void read_output(int fd);
  void await_output_end();  // after the child was reaped: until the reader saw EOF (bounded)

  std::vector<std::string> argv_;
  Options options_;
  pid_t pid_ = -1;
  std::optional<ExitStatus> status_;
  std::thread reader_;

  mutable std::mutex mutex_;
  std::condition_variable line_added_;
  std::vector<std::string> lines_;
  bool output_closed_ = false;
};

}  // namespace rtm_test
