// SPDX-License-Identifier: Apache-2.0
// The runner's steps, shared by run_component (one component, host/runner.h) and
// run_container (several in one process, host/module.h). Not installed.
#pragma once

#include "host/cycle_log.h"
#include "host/name_binding.h"
#include "host/runner.h"
#include "rtm/orb.h"

#include <signal.h>

#include <condition_variable>
#include <mutex>
#include <thread>

#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace rtm::detail {

const char* program_name(const char* argv0);

// Waits for SIGINT/SIGTERM synchronously. The signals are blocked before any thread starts
// (every thread inherits the mask), so none is ever delivered to a handler.
class TerminationSignals {
 public:
  TerminationSignals();
  ~TerminationSignals();
  TerminationSignals(const TerminationSignals&) = delete;
  TerminationSignals& operator=(const TerminationSignals&) = delete;
  int wait() const;

 private:
  sigset_t set_{};
  sigset_t previous_{};
};

// Before any thread exists: the ORB's threads and the activities inherit it.
void pin_process_to_cpu(int cpu);

// Started under chrt: the main thread goes back to SCHED_OTHER, and the priority it had is
// returned for the activities (0 when it had none).
int keep_real_time_for_the_activity(const std::string& name);

// process: a component's own command line (its name, the naming service, the process's
// options). member: one member of rtm-container, whose process options are the container's.
enum class ParseMode { process, member };
// Parses the command line into settings (settings.name, when set, is the default name);
// returns an exit status when the process should stop here (--help: 0, a bad command line: 2).
std::optional<int> parse_command_line(int argc, char** argv, const char* program, const ComponentMain& main,
                                      RunSettings& settings, ParseMode mode);
void add_process_options(CLI::App& app, RunSettings& settings, std::string& access_text);
// --naming (default $RTM_NAMING, else 127.0.0.1:2809), and the address its text names.
void add_naming_option(CLI::App& app, std::string& text);
NamingAddress naming_from(const std::string& text);
std::optional<int> check_endpoints(const char* program, RunSettings& settings);

// Builds the component and its servant, activates it and binds its names; turns it on when
// asked. Throws what the component's factory or the ORB throws; what was made by then is in
// servant, bindings and cycle_log (--log-cycles), for shut_down().
void bring_up(const ComponentMain& main, const RunContext& context, PortableServer::Servant_var<ComponentServant>& servant,
              std::vector<std::unique_ptr<NameBinding>>& bindings, std::unique_ptr<CycleLog>& cycle_log);
// Off, then the cycle log's end (if any), the names, the servant.
void shut_down(PortableServer::Servant_var<ComponentServant>& servant, std::vector<std::unique_ptr<NameBinding>>& bindings,
               std::unique_ptr<CycleLog>& cycle_log, const std::string& name);

// Logs the misses of each component whose contract (or a chain it ends) says MissAction::warn: from a thread of its
// own at SCHED_OTHER, at most one line a second per component, with the counts since the last
// line and the worst case. The cycles only count (rt/cycle_watch.h). Without such a component
// it starts no thread.
class ContractWarner {
 public:
  explicit ContractWarner(std::vector<const ComponentServant*> servants);
  // servant and the members main makes in this process (ComponentMain::members).
  static std::vector<const ComponentServant*> watched(const ComponentMain& main, const ComponentServant* servant);
  ~ContractWarner();  // stops and joins the thread
  ContractWarner(const ContractWarner&) = delete;
  ContractWarner& operator=(const ContractWarner&) = delete;

 private:
  void loop();
  void warn_chains(std::size_t i);
  std::vector<const ComponentServant*> servants_;
  std::vector<CycleWatchStats> seen_;
  std::vector<std::vector<ComponentServant::ChainStatus>> seen_chains_;
  std::mutex mu_;
  std::condition_variable cv_;
  bool stop_ = false;
  std::thread thread_;
};

// The access screen, the certificates and the ORB of the process (into orb); false, after
// one error line, when one of them cannot be had.
bool start_orb(const char* program, const RunSettings& settings, std::optional<Orb>& orb);

}  // namespace rtm::detail
