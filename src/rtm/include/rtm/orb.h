// SPDX-License-Identifier: Apache-2.0
// ORB and POA setup: one omniORB ORB per process, one POA with the local-call shortcut.
#pragma once

#include <omniORB4/CORBA.h>

#include <atomic>
#include <functional>
#include <string>
#include <vector>

namespace rtm {

// What a process adds around the core, process-wide: the host library (host/access.h, host/tls.h: the runner
// and `rtm` link it) sets these before the first Orb. The core calls them and knows nothing more of either. A
// process that sets none serves without the access screen, and its Orb says so (a warning) when it activates
// its first servant: any local user may then change its servants over TCP.
struct ProcessHooks {
  std::function<void()> after_orb_init;  // right after ORB_init, before any servant: the screen
  bool certificates = false;             // omniORB's SSL transport has certificates
  // NamingClient: "" when object, bound at a name of host, is a member of this system, else
  // why not. Throws NotAMember itself never; set only with certificates.
  std::function<std::string(CORBA::Object_ptr object, const std::string& host)> membership_problem;
};
ProcessHooks& process_hooks();

// Owns the process's ORB and the POA every RTM servant is activated in. The POA "rtm" carries omniORB's
// LOCAL_CALLS_SHORTCUT policy: together with the -Wbshortcut stubs of rtm_idl a call on a servant of this
// process costs about a virtual call. Construct one Orb per process (omniORB has one ORB); the destructor
// shuts it down and destroys it, releasing what omniORB allocated. Servants may outlive it: destroying the
// Orb releases them from its POA, and their deactivate() then does nothing.
class Orb {
 public:
  // args: ORB options as on a command line, e.g. {"-ORBendPoint", "giop:unix:/tmp/x.sock"}.
  // Throws std::runtime_error (with the CORBA exception's name) when omniORB refuses them.
  explicit Orb(const std::vector<std::string>& args = {});
  ~Orb();
  Orb(const Orb&) = delete;
  Orb& operator=(const Orb&) = delete;

  CORBA::ORB_ptr orb() const { return orb_.in(); }
  PortableServer::POA_ptr poa() const { return poa_.in(); }

  // Activates servant in poa() and returns its reference. The POA adds a reference count.
  CORBA::Object_var activate(PortableServer::ServantBase* servant);
  // Deactivates servant and waits (bounded, 5 s) until the POA has released it, so that the
  // caller may then destroy it. Never call it from an upcall on that same servant.
  void deactivate(PortableServer::ServantBase* servant);

  // Blocks serving requests until shutdown() (from any thread or a signal-safe flag poller).
  void run();
  // Stops run(); safe from any thread, idempotent.
  void shutdown();

  std::string to_string(CORBA::Object_ptr obj) const;                // IOR text
  CORBA::Object_var from_string(const std::string& ior_or_url) const;  // IOR:, corbaloc:, ...

  // The Orb of this process, or nullptr when none is alive.
  static Orb* instance();

 private:
  CORBA::ORB_var orb_;
  PortableServer::POA_var poa_;
  std::atomic<bool> shut_down_{false};
  bool screened_ = false;  // ProcessHooks::after_orb_init ran
  std::atomic<bool> told_unscreened_{false};
};

}  // namespace rtm
