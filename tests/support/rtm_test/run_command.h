// SPDX-License-Identifier: Apache-2.0
// Runs a command to completion and collects its stdout, stderr and exit code, for tests that
// drive the real `rtm` binary. A command still running at the timeout is killed and the test
// sees exit code -1.
#pragma once

#include "rtm_test/child_process.h"

#include <chrono>
#include <memory>
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

// Starts a component (its output kept, not echoed), appends it to `started` (which stops them
// all when it goes) and waits until it has bound its name.
ChildProcess& start_bound(std::vector<std::unique_ptr<ChildProcess>>& started, const std::vector<std::string>& argv);

}  // namespace rtm_test
