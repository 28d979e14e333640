// SPDX-License-Identifier: Apache-2.0
#include "rtm/orb.h"

#include "rtm/log.h"

#include <omniORB4/omniPolicy.h>

#include <dirent.h>
#include <pwd.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>

namespace rtm {

namespace {
std::atomic<Orb*> g_instance{nullptr};

// omniORB names its giop:unix: sockets /tmp/omni-<user>/<pid, 9 digits>-<time> and leaves them
// behind when a process is killed: those of processes that no longer exist are removed.
void remove_stale_unix_sockets() {
  const passwd* pw = getpwuid(geteuid());
  if (!pw) return;
  const std::string folder = std::string("/tmp/omni-") + pw->pw_name;
  DIR* dir = opendir(folder.c_str());
  if (!dir) return;
  int removed = 0;
  while (const dirent* entry = readdir(dir)) {
    const std::string name = entry->d_name;
    if (name.size() < 11 || name[9] != '-' || name.find_first_not_of("0123456789") != 9) continue;
    const long pid = std::strtol(name.substr(0, 9).c_str(), nullptr, 10);
    if (pid <= 0 || kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;
    const std::string path = folder + "/" + name;
    struct stat st {};
    if (lstat(path.c_str(), &st) != 0 || !S_ISSOCK(st.st_mode) || st.st_uid != geteuid()) continue;
    if (unlink(path.c_str()) == 0) ++removed;
  }
  closedir(dir);
  if (removed > 0) log().debug("removed {} giop:unix: sockets of processes that no longer exist from {}", removed, folder);
}

// omniORB's SSL transport is linked into every program; a process without certificates (host/tls.h) would see
// its warning "SSL transport disabled" at every start. It is the only trace-level-1 message ORB_init gives
// for a usable setup, so that level is lowered for the call unless the user chose a level.
bool user_chose_trace_level(const std::vector<std::string>& args) {
  if (std::getenv("ORBtraceLevel")) return true;
  for (const auto& a : args)
    if (a == "-ORBtraceLevel") return true;
  return false;
}

std::string describe(const CORBA::Exception& e) {
  const char* name = e._name();
  return name ? name : "CORBA exception";
}
}  // namespace

ProcessHooks& process_hooks() {
  static ProcessHooks hooks;
  return hooks;
}

Orb::Orb(const std::vector<std::string>& args) {
  // ORB_init wants a mutable argv; the storage must live through the call only.
  std::vector<std::string> storage;
  storage.reserve(args.size() + 7);
  storage.emplace_back("rtm");
  for (const auto& a : args) storage.push_back(a);
  const auto given = [&](const char* option) { return std::find(args.begin(), args.end(), option) != args.end(); };
  // Callers on this host come over giop:unix:, where the kernel tells a servant who calls
  // (host/access.h); TCP on loopback only, unless the caller names its endpoints.
  if (!given("-ORBendPoint")) storage.insert(storage.end(), {"-ORBendPoint", "giop:tcp:127.0.0.1:", "-ORBendPoint", "giop:unix:"});
  // Only this user (and root) may connect to the giop:unix: socket; omniORB's default is 0777.
  if (!given("-ORBunixTransportPermission")) storage.insert(storage.end(), {"-ORBunixTransportPermission", "0600"});
  std::vector<char*> argv;
  for (auto& s : storage) argv.push_back(s.data());
  int argc = static_cast<int>(argv.size());
  remove_stale_unix_sockets();
  const ProcessHooks& hooks = process_hooks();
  const bool quiet_ssl = !hooks.certificates && !user_chose_trace_level(args);
  const CORBA::ULong trace_level = omniORB::traceLevel;
  try {
    if (quiet_ssl) omniORB::traceLevel = 0;
    orb_ = CORBA::ORB_init(argc, argv.data());
    if (quiet_ssl) omniORB::traceLevel = trace_level;
    screened_ = static_cast<bool>(hooks.after_orb_init);
    if (screened_) hooks.after_orb_init();
    CORBA::Object_var root_obj = orb_->resolve_initial_references("RootPOA");
    PortableServer::POA_var root = PortableServer::POA::_narrow(root_obj);
    PortableServer::POAManager_var manager = root->the_POAManager();
    CORBA::PolicyList policies;
    policies.length(1);
    policies[0] = omniPolicy::create_local_shortcut_policy(omniPolicy::LOCAL_CALLS_SHORTCUT);
    poa_ = root->create_POA("rtm", manager, policies);
    policies[0]->destroy();
    manager->activate();
  } catch (const CORBA::Exception& e) {
    if (quiet_ssl) omniORB::traceLevel = trace_level;
    std::string what = "rtm::Orb: ORB initialisation failed: " + describe(e);
    if (!CORBA::is_nil(orb_)) {
      try {
        orb_->destroy();
      } catch (...) {
      }
    }
    throw std::runtime_error(what);
  }
  if (argc > 1) {
    std::string left;
    for (int i = 1; i < argc; ++i) left += std::string(" ") + argv[static_cast<std::size_t>(i)];
    log().debug("ORB left these arguments unused:{}", left);
  }
  g_instance.store(this);
}

Orb::~Orb() {
  Orb* self = this;
  g_instance.compare_exchange_strong(self, nullptr);
  try {
    shutdown();
    orb_->destroy();
  } catch (const CORBA::Exception& e) {
    log().warn("ORB destroy raised {}", describe(e));
  }
}

CORBA::Object_var Orb::activate(PortableServer::ServantBase* servant) {
  if (!screened_ && !told_unscreened_.exchange(true))
    log().warn("rtm::Orb: this process serves without the access screen: any local user may change its servants "
               "over TCP (host/access.h: configure_access() before the Orb; the runner does)");
  PortableServer::ObjectId_var id = poa_->activate_object(servant);
  return poa_->id_to_reference(id);
}

void Orb::deactivate(PortableServer::ServantBase* servant) {
  CORBA::ULong before = servant->_refcount_value();
  try {
    PortableServer::ObjectId_var id = poa_->servant_to_id(servant);
    poa_->deactivate_object(id);
  } catch (const PortableServer::POA::ServantNotActive&) {
    return;
  } catch (const CORBA::Exception& e) {
    log().warn("deactivate: {}", describe(e));
    return;
  }
  // The POA drops its reference once the last call in progress on the servant has returned.
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (servant->_refcount_value() >= before) {
    if (std::chrono::steady_clock::now() > give_up) {
      log().error("deactivate: a call on the servant did not return within 5 s");
      return;
    }
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
}

void Orb::run() { orb_->run(); }

void Orb::shutdown() {
  if (shut_down_.exchange(true)) return;
  try {
    orb_->shutdown(true);
  } catch (const CORBA::BAD_INV_ORDER&) {
    // Called from an upcall: shut down without waiting.
    orb_->shutdown(false);
  }
}

std::string Orb::to_string(CORBA::Object_ptr obj) const {
  CORBA::String_var s = orb_->object_to_string(obj);
  return std::string(s.in());
}

CORBA::Object_var Orb::from_string(const std::string& ior_or_url) const {
  try {
    return orb_->string_to_object(ior_or_url.c_str());
  } catch (const CORBA::Exception& e) {
    throw std::invalid_argument("rtm::Orb: not an object reference: '" + ior_or_url + "' (" + describe(e) + ")");
  }
}

Orb* Orb::instance() { return g_instance.load(); }

}  // namespace rtm

// omniORB's shortcut stubs (-Wbshortcut) cache the servant in the object reference (_enableShortcut) on a
// collocated call while other threads calling through the same reference read that pointer: an unsynchronised
// pointer-sized store omniORB relies on. It is suppressed here (every program using RTM servants links this
// file) rather than in a file each ThreadSanitizer run would have to name.
#if defined(__SANITIZE_THREAD__)
extern "C" const char* __tsan_default_suppressions() { return "race:_enableShortcut\n"; }
#endif
