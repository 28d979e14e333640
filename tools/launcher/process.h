// SPDX-License-Identifier: Apache-2.0
// The launcher's processes: started detached, known by pid and start time, stopped with a
// grace period. Internal to tools/launcher (rtm up/down and the private naming service).
#pragma once

#include "launcher/launcher.h"

#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace rtm::cli {

// /proc/<pid>/stat: state (field 3) and start time (field 22). Empty state when gone.
std::pair<char, unsigned long long> proc_stat(pid_t pid);

// The last lines of a log, each on a line of its own indented by four spaces.
std::string log_tail(const std::filesystem::path& log, int lines);

// Starts argv (argv[0] a path) detached: a grandchild in its own session, so it outlives the
// caller and is reaped by init; its output goes to log. Returns its pid.
pid_t spawn_detached(const std::vector<std::string>& argv, const std::filesystem::path& log);

// SIGTERM to each process still alive (last first), SIGKILL to those alive after grace (their
// names into *killed), then a bounded wait until they are gone.
void stop_processes(const std::vector<LaunchedProcess>& procs, std::chrono::milliseconds grace,
                    std::vector<std::string>* killed);

}  // namespace rtm::cli
