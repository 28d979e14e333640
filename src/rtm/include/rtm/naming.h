// SPDX-License-Identifier: Apache-2.0
// Naming: where RT components are found.
//
// A component's RtComponent reference is bound in the CORBA naming service (omniNames) at
// `<host>.host_cxt/<name>.rtc` (NameComponent id/kind {"<host>","host_cxt"}, {"<name>","rtc"}), the
// OpenRTM convention, so OpenRTM's tools can browse an RTM system. Two layers here:
//   - NamingAddress / ComponentPath: plain values, parsed and printed.
//   - NamingClient: one naming service; bind, unbind, resolve and list, each call bounded by a timeout,
//     every failure a NamingError whose message a user can act on.
// The runner's NameBinding (host/name_binding.h) keeps one component bound for its lifetime on top of them.
#pragma once

#include <omniORB4/CORBA.h>
#include <omniORB4/Naming.hh>

#include <RTM.hh>

#include <chrono>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace rtm {

// ---- Values ----

// Any failure to reach or use the naming service, or to find a component in it.
class NamingError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// NameBinding's constructor: the name is bound to another component that still answers.
class NameTaken : public NamingError {
 public:
  using NamingError::NamingError;
};

// resolve_component with certificates configured (host/tls.h): the name leads to an object that
// is not a member of this system on the name's host (another authority's or another host's
// certificate, another user's process, plain TCP), or no TLS connection to it can be made.
class NotAMember : public NamingError {
 public:
  using NamingError::NamingError;
};

// host:port of a naming service (omniNames' default port is 2809).
struct NamingAddress {
  std::string host = "127.0.0.1";
  std::uint16_t port = 2809;

  // Parses "host:port", "host" (port 2809) or "[v6addr]:port". Throws std::invalid_argument
  // with the offending text on a bad port or an empty host.
  static NamingAddress parse(std::string_view text);
  // $RTM_NAMING when set, else 127.0.0.1:2809.
  static NamingAddress from_environment();

  std::string to_string() const;  // "127.0.0.1:2809"
  std::string corbaloc() const;   // "corbaloc::127.0.0.1:2809/NameService"
  bool operator==(const NamingAddress&) const = default;
};

// The one rule for a component's (and a system's) name, used by the runner (--name), `rtm up`
// (its system file) and the naming path: 1 to 64 of A-Z a-z 0-9 _ - . , not starting with '.'
// or '-'. Such a name is safe as a file name in the runtime folder (no '/', no "..") and as a
// naming-service id. Throws std::invalid_argument saying what is wrong, naming `what`.
void check_name(std::string_view name, std::string_view what = "component name");

// Where one component is bound: <host>.host_cxt/<name>.rtc
struct ComponentPath {
  std::string host;  // host context id, normally this machine's host name
  std::string name;  // component name, e.g. "sensor0"

  // "host/name" -> {host, name}; "name" -> {"", name} (host to be searched). Throws
  // std::invalid_argument on an empty part or more than one '/'.
  static ComponentPath parse(std::string_view text);
  // {this machine's host name, name}
  static ComponentPath on_this_host(std::string name);

  std::string to_string() const;      // "host.host_cxt/name.rtc"
  CosNaming::Name to_name() const;    // the two NameComponents
  bool operator==(const ComponentPath&) const = default;
};

// This machine's host name as the host context uses it.
std::string local_host_name();

// One component found in the naming service.
struct ComponentEntry {
  ComponentPath path;
  CORBA::Object_var object;  // the bound reference (RtComponent or a derived interface)
};

// ---- NamingClient: one naming service ----

// Talks to one naming service. Constructing it makes no remote call, so it succeeds whether or not the
// service is up; each operation contacts it and throws NamingError on failure, e.g. "naming service at
// 127.0.0.1:2809 unreachable: TRANSIENT". Thread-safe as far as omniORB object references are (every method
// is const).
class NamingClient {
 public:
  static constexpr std::chrono::milliseconds kDefaultCallTimeout{2000};

  NamingClient(CORBA::ORB_ptr orb, NamingAddress address,
               std::chrono::milliseconds call_timeout = kDefaultCallTimeout);

  const NamingAddress& address() const { return address_; }

  // Binds object at path, creating the host context when missing and replacing a binding of the same name.
  void bind(const ComponentPath& path, CORBA::Object_ptr object) const;
  // Removes the binding; a binding already gone is not an error. The host context stays.
  void unbind(const ComponentPath& path) const;
  // The object bound at path. Throws NamingError "no component <path> in naming service at .."
  // when nothing is bound there.
  CORBA::Object_var resolve_object(const ComponentPath& path) const;
  // True when path is bound (to anything); throws only when the service cannot be reached.
  bool is_bound(const ComponentPath& path) const;

  // Resolves "host/name", or "name" searched in every host context, to an RtComponent, and stores where it
  // was found in *found when given. Throws NamingError when nothing matches, or when "name" matches on more
  // than one host (the message lists them). With certificates configured (host/tls.h) it first checks that
  // the component is a member of this system on that host, and throws NotAMember with the reason when it is
  // not: a name re-bound by someone else leads nowhere.
  RTM::RtComponent_var resolve_component(std::string_view host_slash_name, ComponentPath* found = nullptr) const;
  // The same check for an object bound at path (a listing): throws NotAMember.
  void check_member(const ComponentPath& path, CORBA::Object_ptr object) const;
  // Every <host>.host_cxt/<name>.rtc binding, sorted by host then name.
  std::vector<ComponentEntry> list_components() const;

 private:
  CosNaming::NamingContext_var root() const;
  [[noreturn]] void throw_unreachable(const CORBA::SystemException& ex) const;
  template <class Call>
  auto guarded(Call&& call) const -> decltype(call());

  CORBA::ORB_var orb_;
  NamingAddress address_;
  std::chrono::milliseconds call_timeout_;
};

}  // namespace rtm
