// SPDX-License-Identifier: Apache-2.0
// `rtm up` / `rtm down`: launching the processes of a system file and tearing them down.
//
// `up` starts each component detached (own session, output to a log file), or one rtm-container
// for the components of a host, records it in a state file at once, waits until each component
// is bound in the naming service, then makes the connections and turns on what the file lists.
// When anything fails, it stops what it started and says which component did not come up and
// why. `down` reads the state file: turns off, disconnects, sends SIGTERM (SIGKILL after a grace
// period) to each process once and waits until every process is gone. The state file lives in
// $XDG_RUNTIME_DIR/rtm (or /tmp/rtm-<uid>), named after the system; each process is recorded
// with its start time (so that a recycled pid is never killed) and the components it binds.
#pragma once

#include "browser/browser.h"
#include "launcher/system_file.h"

#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

namespace rtm::cli {

struct LaunchedProcess {
  std::string name;
  pid_t pid = 0;
  unsigned long long start_time = 0;  // /proc/<pid>/stat field 22, guards against pid reuse
  std::filesystem::path log;
  // The components it binds: itself alone, or the members of a host (name is the host's).
  std::vector<std::string> members{};
};

struct SystemState {
  std::string system;
  std::string naming;
  std::filesystem::path file;
  std::vector<LaunchedProcess> processes;
  std::vector<SystemFile::Connection> connections;
  std::vector<std::string> activated;

  static std::filesystem::path directory();
  static std::filesystem::path path_for(const std::string& system);
  void save() const;
  // Throws SystemFileError when there is no state for the system ("is it up?").
  static SystemState load(const std::string& system);
};

struct LaunchOptions {
  std::chrono::milliseconds bind_timeout{10000};
  std::chrono::milliseconds stop_timeout{5000};
  // A parameter set of the file (`rtm up --set NAME`): its values over each component's
  // parameters. "" for the parameters alone.
  std::string parameter_set;
  // A file with a contract or a chain is checked first (launcher/timing_check.h): one that
  // cannot keep them is refused, naming the component, the CPU and the numbers, unless force,
  // which starts it anyway after saying each refusal (progress).
  bool force = false;
  std::function<void(const std::string&)> progress;  // one line per step
  // Polled between the steps of system_up and while it waits: true (Ctrl-C) stops what was
  // started and throws LaunchInterrupted.
  std::function<bool()> interrupted;
};

// One process `rtm up` starts: a component alone, or the rtm-container of a host.
struct ProcessToStart {
  std::string name;                  // the component's, or the host's
  std::vector<std::string> command;  // argv; argv[0] a path
  std::vector<std::string> members;  // the components it binds, in the file's order
};

// Where a program of the file is (find_program; tests give their own).
using ProgramFinder =
    std::function<std::filesystem::path(const std::string& program, const std::filesystem::path& base)>;

// The processes of a system, in the file's order of their first components, each host once:
//   a component alone:  PROGRAM ARGS... --name NAME --naming ADDR
//   a host:             rtm-container --name HOST --naming ADDR -- M1 PROGRAM1 ARGS1... -- M2 ...
// Programs are found with `find`; a member's program is passed as an absolute path (the
// container finds the module beside it), or as written when it is a bare name no program
// answers to (the container may still know its module). Throws what `find` throws
// (SystemFileError: a program not found) for a program that starts a process or has a '/'.
std::vector<ProcessToStart> processes_to_start(const SystemFile& file, const std::string& naming,
                                               const ProgramFinder& find = find_program);

// system_up was interrupted; everything it had started is stopped again.
class LaunchInterrupted : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Starts the system; on failure stops what it started and throws (BrowseError or
// SystemFileError) with the reason. Returns the state it saved.
SystemState system_up(const SystemFile& file, const Browser& browser, const NamingAddress& naming,
                      const LaunchOptions& options);

// Stops a system started by system_up. Returns the names of processes that had to be killed.
std::vector<std::string> system_down(const SystemState& state, const Browser* browser,
                                     const LaunchOptions& options);

// True while the recorded process still runs (same start time; a zombie only while threads of
// it are still exiting, as they hold its files).
bool process_alive(const LaunchedProcess& p);

}  // namespace rtm::cli
