// SPDX-License-Identifier: Apache-2.0
// Who is at the other end of a connected socket of this host, as the kernel says: what access
// control (host/access.h) and `rtm up` (which process serves a name) trust, since a process can
// lie about itself but not about this. No CORBA here.
#pragma once

#include <sys/types.h>

#include <optional>

namespace rtm {

struct SocketPeer {
  uid_t uid = 0;               // the user of the process at the other end
  std::optional<pid_t> pid;    // unix socket: that process (for the connecting side: the listener)
  std::optional<ino_t> inode;  // TCP: the peer socket's inode, to find its process in /proc/<pid>/fd
};

// A unix socket: its peer credentials (SO_PEERCRED, recorded by the kernel at connect). A TCP
// socket whose peer is a socket of this host (of this network namespace): that socket's owner
// and inode, asked of the kernel for that one socket (NETLINK_SOCK_DIAG, the look-up `ss`
// makes: its cost does not grow with the host's sockets, which any user can multiply), or
// read from /proc/net/tcp or tcp6 where the kernel does not answer. nullopt for a peer on
// another host, a socket of no such kind, or an unconnected one.
std::optional<SocketPeer> socket_peer(int fd);

// Whether process pid has the socket with inode open (/proc/<pid>/fd/* -> socket:[inode]).
bool process_holds_socket(pid_t pid, ino_t inode);

}  // namespace rtm
