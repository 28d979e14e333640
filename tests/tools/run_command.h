// Runs a command to completion and collects its stdout, stderr and exit code, for tests that
// drive the real `rtm` binary. A command still running at the timeout is killed and the test
// sees exit code -1.
#pragma once

#include <chrono>
#include <string>
#include <vector>

namespace rtm_test {

struct CommandResult {
  int exit_code = -1;  // -1: killed at the timeout or by a signal
  std::string out, err;
};

CommandResult run_command(const std::vector<std::string>& argv,
                          const std::vector<std::string>& extra_env = {},
                          std::chrono::milliseconds timeout = std::chrono::seconds(20));

}  // namespace rtm_test
