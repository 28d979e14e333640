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
};

constexpr const char* kUsage =
    "Members follow the container's own options, each after a --: its component name, the program it "
    "would otherwise run as (rtm-controller, a program's path, or a module's path ending in .so), then "
    "that program's options without --name and --naming:\n"
    "  rtm-container --name cell0 -- controller0 rtm-controller --gain 1 1 1 0 0 0 -- actuator0 rtm-actuator";

}  // namespace

int run_container(int argc, char** argv) {
  using namespace detail;
  const char* program = program_name(argc > 0 ? argv[0] : "rtm-container");
  TerminationSignals signals;

  // ---- the command line: the container's options, then one group per member ----
  std::vector<std::string> own{argc > 0 ? argv[0] : "rtm-container"};
  std::vector<std::vector<std::string>> groups;
  for (int i = 1; i < argc; ++i) {
    if (std::string_view(argv[i]) == "--") groups.emplace_back();
    else if (groups.empty()) own.emplace_back(argv[i]);
    else groups.back().emplace_back(argv[i]);
  }
  std::vector<const char*> own_argv;
  for (const auto& arg : own) own_argv.push_back(arg.c_str());
  const SplitArguments split = split_orb_arguments(static_cast<int>(own_argv.size()), own_argv.data());
  RunSettings process;
  process.orb_args = split.orb;
  std::string name;
  std::string naming_text;
  std::string access_text = "owner";
  CLI::App app("rtm-container: several components in one process, each loaded from its module and bound "
               "under its own name; connections between them take the in-process path",
               program);
  app.add_option("--name", name, "this process's name (a system file's host)")->required();
  app.add_option("--naming", naming_text, "naming service host:port")
      ->default_str(NamingAddress::from_environment().to_string())
      ->envname("RTM_NAMING");
  app.add_option("--cpu", process.cpu, "pin the process to this CPU")->check(CLI::NonNegativeNumber);
  add_process_options(app, process, access_text);
  app.footer(std::string(kUsage) + "\nOptions -ORB<name> <value> (before the first --) go to omniORB unchanged.");
  std::vector<const char*> split_argv;
  for (const auto& arg : split.own) split_argv.push_back(arg.c_str());
  try {
    app.parse(static_cast<int>(split_argv.size()), split_argv.data());
    check_name(name, "container name");
    process.access = *parse_access_policy(access_text);
    process.naming = naming_text.empty() ? NamingAddress::from_environment() : NamingAddress::parse(naming_text);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "%s: %s\n", program, e.what());
    return 2;
  }
  if (auto status = check_endpoints(program, process)) return *status;
  if (groups.empty()) {
    std::fprintf(stderr, "%s: no members. %s\n", program, kUsage);
    return 2;
  }

  // ---- each member: its module, its own command line ----
  std::vector<Member> members(groups.size());
  std::set<std::string> names;
  int highest_priority = 0;
  for (std::size_t i = 0; i < groups.size(); ++i) {
    const auto& group = groups[i];
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
    std::vector<char*> member_argv;
    std::vector<std::string> texts(group.begin() + 1, group.end());
    for (auto& text : texts) member_argv.push_back(text.data());
    m.settings.name = group[0];
    const std::string shown = fmt::format("{} ({})", group[0], program_name(m.program.c_str()));
    if (auto status = parse_command_line(static_cast<int>(member_argv.size()), member_argv.data(), shown.c_str(), m.main,
                                         m.settings, ParseMode::member))
      return *status;
    m.settings.naming = process.naming;
    m.settings.access = process.access;
    m.settings.endpoints = process.endpoints;
    m.settings.tls_folder = process.tls_folder;
    m.settings.lock_memory = process.lock_memory;
    highest_priority = std::max(highest_priority, m.settings.rt_priority);
  }

  if (process.cpu >= 0) pin_process_to_cpu(process.cpu);
  // Started under chrt: every member without --rt-priority of its own takes that priority.
  const int inherited = keep_real_time_for_the_activity(name);
  for (Member& m : members) {
    if (m.settings.rt_priority == 0) m.settings.rt_priority = inherited;
    highest_priority = std::max(highest_priority, m.settings.rt_priority);
  }
  // One process, one priority for the threads on a datum's path that are no activity (a CAN
  // receive thread, a delivery thread, an ORB thread serving an admitted put): the highest.
  set_path_thread_priority(highest_priority);

  std::optional<Orb> orb;
  if (!start_orb(program, process, orb)) return 1;

  int status = 0;
  for (Member& m : members) {
    try {
      bring_up(m.main, RunContext{m.settings, *orb}, m.servant, m.bindings);
      continue;
    } catch (const CORBA::Exception& e) {
      log().error("{}: {} could not start: CORBA {}", name, m.settings.name, e._name());
    } catch (const std::exception& e) {
      log().error("{}: {} could not start: {}", name, m.settings.name, e.what());
    }
    status = 1;
    break;
  }
  if (status == 0) {
    std::string listed;
    for (const Member& m : members) listed.append(listed.empty() ? "" : ", ").append(m.settings.name);
    log().info("{}: {} members up: {}", name, members.size(), listed);
    const int received = signals.wait();
    log().info("stopping {} ({})", name, received == SIGINT ? "SIGINT" : "SIGTERM");
  }
  // ---- shut down in order, the last member first ----
  for (auto it = members.rbegin(); it != members.rend(); ++it) shut_down(it->servant, it->bindings, it->settings.name);
  members.clear();
  orb.reset();
  return status;
}

}  // namespace rtm
