// SPDX-License-Identifier: Apache-2.0
// Access control: by default only the user who started a component may change it.
//
// No secret crosses the wire. A component asks the kernel who is calling, once per connection
// when it accepts it (host/socket_peer.h): over its giop:unix: socket the peer credentials
// (SO_PEERCRED) name the caller's user; over TCP from this host the caller's socket in
// /proc/net/tcp does. A change (on, off, reset, set_parameter, subscribe, unsubscribe, put and
// its variants, hold, release, admit_writer) is let through when that user is the component's
// own (or root, who may do anything to the process anyway), or when it arrives over a giop:ssl:
// connection whose peer presented a certificate of this process's authority (host/tls.h: the
// credential across hosts). Otherwise it is refused with CORBA::NO_PERMISSION before its
// arguments are read: minor kAccessRefusedMinor when the caller is another user,
// kCallerUnknownMinor when it came over plain TCP from another host, where nobody can tell who
// is calling. Reading (get, state, statistics, ports, describe, ...) needs no credential at
// all. Calls inside one process take omniORB's local shortcut and are not checked.
//
// A client that knows only the 2004 IDL (idl/RTM.idl) and reaches the component over TCP is
// let change it when the owner starts the component with --access open (AccessPolicy::open).
#pragma once

#include "rtm/data.h"

#include <omniORB4/CORBA.h>

#include <sys/types.h>

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace rtm {

enum class AccessPolicy : std::uint8_t {
  owner,  // changes only from this user's processes on this host, or a certificate (the default)
  open,   // anyone who can reach the endpoints may change it (2004 clients)
};
// "owner" or "open"; nullopt otherwise.
std::optional<AccessPolicy> parse_access_policy(std::string_view text);

// Sets what this process's servants require; before rtm::Orb is made (the default is owner).
void configure_access(AccessPolicy policy);
// rtm::Orb, right after ORB_init (omniORB has no interceptors before it): adds the
// interceptors, once per process.
void register_access_interceptors();

// Whether operation `name` (a GIOP operation name) changes a component or its ports.
bool is_change_operation(std::string_view name);
// Whether a caller running as uid may change this process's servants: this process's own
// user, or root.
bool is_owner_uid(uid_t uid);

// How a call went, as the kernel and the TLS handshake tell: over which transport, and who
// is at the other end.
enum class Transport : std::uint8_t { unix_socket, tcp, tls, other };
struct Peer {
  Transport transport = Transport::other;
  std::string address;            // omniORB's connection address, e.g. "giop:ssl:10.0.0.2:4711"
  std::optional<uid_t> uid;       // unix socket, TCP on this host: the user of the process at the other end
  std::optional<pid_t> pid;       // unix socket: that process
  std::optional<ino_t> socket_inode;  // TCP on this host: its socket (host/socket_peer.h)
  std::string identity;           // tls: the verified certificate's common name, e.g. "op@hostb"
};

// The process that serves `object`, learnt from one call to it (_non_existent) and the
// connection it went over. nullopt when the object is in this process (no connection).
// Throws the call's CORBA::SystemException (TRANSIENT for a dead or unreachable object).
std::optional<Peer> peer_of(CORBA::Object_ptr object);

// The same screen refuses every put before its argument is read when the datum's type is no
// data type (an any holding an any, whose unmarshalling omniORB 4.2 does in time doubling per
// level; an object reference, a value, a TypeCode): CORBA::BAD_PARAM (minor
// kNotPlainDataMinor), whatever the access policy. Refusals of either kind are counted and
// logged (the first three, then every thousandth). The minor codes, and the sentence a refused
// change gets (access_refusal_text), are the core's (rtm/data.h): ports report refusals too.

}  // namespace rtm
