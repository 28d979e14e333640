// SPDX-License-Identifier: Apache-2.0
// rtm-container: several components in one process, each loaded from its module
// (host/module.h), each bound under its own name and switched on and off on its own; the
// process's ORB, endpoints, access screen and certificates are shared by all.
#include "host/module.h"
#include "host/tls.h"
#include "rtm/log.h"
#include "runner_parts.h"

#include <CLI/CLI.hpp>
#include <dlfcn.h>
#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <mutex>
#include <set>
#include <stdexcept>

namespace rtm {

namespace {

std::string folder_of(const std::string& path) {
  const std::size_t slash = path.rfind('/');
  return slash == std::string::npos ? std::string(".") : path.substr(0, slash);
}

std::string own_folder() {
  char path[4096];
  const ssize_t n = ::readlink("/proc/self/exe", path, sizeof path - 1);
  if (n <= 0) return ".";
  return folder_of(std::string(path, static_cast<std::size_t>(n)));
}

// Where the module of `program` may be, in the order looked.
std::vector<std::string> module_candidates(const std::string& program) {
  const bool has_path = program.find('/') != std::string::npos;
  if (has_path && program.ends_with(".so")) return {program};
  std::string file = program.substr(program.rfind('/') + 1);  // npos + 1 == 0
  if (!file.ends_with(".so")) file += ".so";
  std::vector<std::string> candidates;
  if (const char* path = std::getenv("RTM_MODULE_PATH")) {
    std::string_view rest(path);
    while (!rest.empty()) {
      const std::size_t colon = rest.find(':');
      const std::string_view dir = rest.substr(0, colon);
      if (!dir.empty()) candidates.push_back(std::string(dir).append("/").append(file));
      rest = colon == std::string_view::npos ? std::string_view() : rest.substr(colon + 1);
    }
  }
  if (has_path) candidates.push_back(folder_of(program).append("/../lib/rtm/modules/").append(file));
  candidates.push_back(own_folder().append("/../lib/rtm/modules/").append(file));
  return candidates;
}

// Code another user could have written is not loaded: the file must be this user's or root's
// and writable by no one else.
void check_owner(const std::string& file, const struct stat& st) {
  if (st.st_uid != ::geteuid() && st.st_uid != 0)
    throw std::runtime_error(file + ": belongs to another user (uid " + std::to_string(st.st_uid) + "); not loaded");
  if ((st.st_mode & (S_IWGRP | S_IWOTH)) != 0)
    throw std::runtime_error(file + ": writable by others; not loaded");
}

}  // namespace

const ComponentModule& load_component_module(const std::string& program) {
  static std::mutex mutex;
  static std::map<std::string, const ComponentModule*> loaded;
  std::lock_guard lock(mutex);
  const std::vector<std::string> candidates = module_candidates(program);
  for (const std::string& file : candidates) {
    struct stat st {};
    if (::stat(file.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) continue;
    if (auto it = loaded.find(file); it != loaded.end()) return *it->second;
    check_owner(file, st);
    // Kept loaded until the process ends: servants of its code live until the ORB is gone.
    void* handle = ::dlopen(file.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (handle == nullptr) throw std::runtime_error(file + ": " + ::dlerror());
    void* entry = ::dlsym(handle, RTM_COMPONENT_MODULE_SYMBOL);
    if (entry == nullptr)
      throw std::runtime_error(file + ": no component module (no " RTM_COMPONENT_MODULE_SYMBOL
                                      "; a component's source ends in RTM_COMPONENT(...), host/module.h)");
    const ComponentModule* module = reinterpret_cast<const ComponentModule* (*)()>(entry)();
    if (module == nullptr || module->abi != kComponentModuleAbi || module->make == nullptr)
      throw std::runtime_error(fmt::format("{}: built against another RTM (module ABI {:#x}, this one {:#x}): rebuild it",
                                           file, module ? module->abi : 0u, kComponentModuleAbi));
    loaded.emplace(file, module);
    return *module;
  }
  std::string looked;
  for (const std::string& file : candidates) looked.append(looked.empty() ? "" : ", ").append(file);
  throw std::runtime_error("no module for " + program + " (looked for " + looked + ")");
}

namespace {

struct Member {
  std::string program;
  ComponentMain main;
  RunSettings settings;
  PortableServer::Servant_var<ComponentServant> servant;
  std::vector<std::unique_ptr<NameBinding>> bindings;
  std::unique_ptr<CycleLog> cycle_log;
};

constexpr const char* kUsage =
    "Members follow the container's own options, each after a --: its component name, the program it "
    "would otherwise run as (rtm-controller, a program's path, or a module's path ending in .so), then "
    "that program's options without --name and --naming:\n"
    "  rtm-container --name cell0 -- controller0 rtm-controller --gain 1 1 1 0 0 0 -- actuator0 rtm-actuator";

// The container's own command line, before the first --, and one group of words per member.
struct ContainerLine {
  std::string name;
  RunSettings process;
  std::vector<std::vector<std::string>> groups;
};

// An exit status when the process should stop here (--help: 0, a bad command line: 2).
std::optional<int> parse_container_line(int argc, char** argv, const char* program, ContainerLine& line) {
  using namespace detail;
  std::vector<std::string> own{argc > 0 ? argv[0] : "rtm-container"};
  for (int i = 1; i < argc; ++i) {
    if (std::string_view(argv[i]) == "--") line.groups.emplace_back();
    else if (line.groups.empty()) own.emplace_back(argv[i]);
    else line.groups.back().emplace_back(argv[i]);
  }
  std::vector<const char*> own_argv;
  for (const auto& arg : own) own_argv.push_back(arg.c_str());
  const SplitArguments split = split_orb_arguments(static_cast<int>(own_argv.size()), own_argv.data());
  line.process.orb_args = split.orb;
  std::string naming_text;
  std::string access_text = "owner";
  CLI::App app("rtm-container: several components in one process, each loaded from its module and bound "
               "under its own name; connections between them take the in-process path",
               program);
  app.add_option("--name", line.name, "this process's name (a system file's host)")->required();
  add_naming_option(app, naming_text);
  app.add_option("--cpu", line.process.cpu, "pin the process to this CPU")->check(CLI::NonNegativeNumber);
  add_process_options(app, line.process, access_text);
  app.footer(std::string(kUsage) + "\nOptions -ORB<name> <value> (before the first --) go to omniORB unchanged.");
  std::vector<const char*> split_argv;
  for (const auto& arg : split.own) split_argv.push_back(arg.c_str());
  try {
    app.parse(static_cast<int>(split_argv.size()), split_argv.data());
    check_name(line.name, "container name");
    line.process.access = *parse_access_policy(access_text);
    line.process.naming = naming_from(naming_text);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "%s: %s\n", program, e.what());
    return 2;
  }
  if (auto status = check_endpoints(program, line.process)) return status;
  if (line.groups.empty()) {
    std::fprintf(stderr, "%s: no members. %s\n", program, kUsage);
    return 2;
  }
  return std::nullopt;
}

// Each member's module and its own command line, into members (one per group); the process's
// settings are theirs. An exit status when the process should stop here (a bad member: 2, no
// module: 1).
std::optional<int> prepare_members(const char* program, const ContainerLine& line, std::vector<Member>& members) {
  using namespace detail;
  std::set<std::string> names;
  for (std::size_t i = 0; i < line.groups.size(); ++i) {
    const auto& group = line.groups[i];
    Member& m = members[i];
    if (group.size() < 2) {
      std::fprintf(stderr, "%s: member %zu: want NAME PROGRAM [OPTIONS...] after --\n", program, i + 1);
      return 2;
    }
    try {
      check_name(group[0]);
      if (!names.insert(group[0]).second) throw std::invalid_argument("member " + group[0] + " is given twice");
    } catch (const std::invalid_argument& e) {
      std::fprintf(stderr, "%s: %s\n", program, e.what());
      return 2;
    }
    m.program = group[1];
    try {
      m.main = load_component_module(m.program).make();
    } catch (const std::exception& e) {
      std::fprintf(stderr, "%s: %s: %s\n", program, group[0].c_str(), e.what());
      return 1;
    }
    if (!m.main.create && !m.main.create_with_orb) {
      std::fprintf(stderr, "%s: %s: %s makes no component factory\n", program, group[0].c_str(), m.program.c_str());
      return 1;
    }
    std::vector<std::string> words(group.begin() + 1, group.end());
    std::vector<char*> member_argv;
    for (auto& word : words) member_argv.push_back(word.data());
    m.settings.name = group[0];
    const std::string shown = fmt::format("{} ({})", group[0], program_name(m.program.c_str()));
    if (auto status = parse_command_line(static_cast<int>(member_argv.size()), member_argv.data(), shown.c_str(), m.main,
                                         m.settings, ParseMode::member))
      return status;
    m.settings.naming = line.process.naming;
    m.settings.access = line.process.access;
    m.settings.endpoints = line.process.endpoints;
    m.settings.tls_folder = line.process.tls_folder;
    m.settings.lock_memory = line.process.lock_memory;
  }
  return std::nullopt;
}

// Started under chrt, every member without --rt-priority of its own takes that priority. One
// process, one priority for the threads on a datum's path that are no activity (a CAN receive
// thread, a delivery thread, an ORB thread serving an admitted put): the highest member's.
void set_priorities(const std::string& name, std::vector<Member>& members) {
  const int inherited = detail::keep_real_time_for_the_activity(name);
  int highest = 0;
  for (Member& m : members) {
    if (m.settings.rt_priority == 0) m.settings.rt_priority = inherited;
    highest = std::max(highest, m.settings.rt_priority);
  }
  set_path_thread_priority(highest);
}

}  // namespace

int run_container(int argc, char** argv) {
  using namespace detail;
  const char* program = program_name(argc > 0 ? argv[0] : "rtm-container");
  TerminationSignals signals;
  ContainerLine line;
  if (auto status = parse_container_line(argc, argv, program, line)) return *status;
  std::vector<Member> members(line.groups.size());  // made in place: a Member does not move
  if (auto status = prepare_members(program, line, members)) return *status;
  if (line.process.cpu >= 0) pin_process_to_cpu(line.process.cpu);
  set_priorities(line.name, members);
  std::optional<Orb> orb;
  if (!start_orb(program, line.process, orb)) return 1;

  int status = 0;
  for (Member& m : members) {
    try {
      bring_up(m.main, RunContext{m.settings, *orb}, m.servant, m.bindings, m.cycle_log);
      continue;
    } catch (const CORBA::Exception& e) {
      log().error("{}: {} could not start: CORBA {}", line.name, m.settings.name, e._name());
    } catch (const std::exception& e) {
      log().error("{}: {} could not start: {}", line.name, m.settings.name, e.what());
    }
    status = 1;
    break;
  }
  if (status == 0) {
    std::string listed;
    for (const Member& m : members) listed.append(listed.empty() ? "" : ", ").append(m.settings.name);
    log().info("{}: {} members up: {}", line.name, members.size(), listed);
    std::vector<const ComponentServant*> servants;
    for (const Member& m : members)
      for (const ComponentServant* s : ContractWarner::watched(m.main, m.servant.in())) servants.push_back(s);
    const ContractWarner warner(std::move(servants));
    const int received = signals.wait();
    log().info("stopping {} ({})", line.name, received == SIGINT ? "SIGINT" : "SIGTERM");
  }
  // ---- shut down in order, the last member first ----
  for (auto it = members.rbegin(); it != members.rend(); ++it) shut_down(it->servant, it->bindings, it->cycle_log, it->settings.name);
  members.clear();
  orb.reset();
  return status;
}

}  // namespace rtm
