// SPDX-License-Identifier: Apache-2.0
#include "rtm/socket_peer.h"

#include <arpa/inet.h>
#include <dirent.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cstdint>
#include <optional>
#include <string_view>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>

namespace rtm {

namespace {

// An address as /proc/net/tcp prints it: each 32-bit word of the address as it lies in memory,
// read as a host-order number, in upper-case hex, then ':' and the port.
std::string proc_form(const void* address, std::size_t words, std::uint16_t port_network_order) {
  std::array<std::uint32_t, 4> word{};
  std::memcpy(word.data(), address, words * 4);
  std::string out;
  char buffer[16];
  for (std::size_t i = 0; i < words; ++i) {
    std::snprintf(buffer, sizeof buffer, "%08X", word[i]);
    out += buffer;
  }
  std::snprintf(buffer, sizeof buffer, ":%04X", ntohs(port_network_order));
  return out + buffer;
}

// Both ends of a TCP connection in /proc/net/tcp's form, for the table `table`; a v4-mapped
// IPv6 pair is also looked for as IPv4 (the peer may be an IPv4 socket).
struct Ends {
  std::string table;
  std::string peer, ours;
};

std::optional<SocketPeer> look_up(const Ends& ends) {
  std::ifstream in(ends.table);
  std::string line;
  std::getline(in, line);  // the header
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string slot, local, remote, state, queues, timer, retransmits, uid, timeout, inode;
    if (!(fields >> slot >> local >> remote >> state >> queues >> timer >> retransmits >> uid >> timeout >> inode))
      continue;
    if (local != ends.peer || remote != ends.ours) continue;
    SocketPeer peer;
    peer.uid = static_cast<uid_t>(std::stoul(uid));
    peer.inode = static_cast<ino_t>(std::stoull(inode));
    return peer;
  }
  return std::nullopt;
}

bool v4_mapped(const in6_addr& a) { return IN6_IS_ADDR_V4MAPPED(&a); }

std::optional<SocketPeer> tcp_peer(int fd) {
  sockaddr_storage ours{}, theirs{};
  socklen_t our_size = sizeof ours, their_size = sizeof theirs;
  if (::getsockname(fd, reinterpret_cast<sockaddr*>(&ours), &our_size) != 0 ||
      ::getpeername(fd, reinterpret_cast<sockaddr*>(&theirs), &their_size) != 0 || ours.ss_family != theirs.ss_family)
    return std::nullopt;
  if (ours.ss_family == AF_INET) {
    const auto& o = reinterpret_cast<const sockaddr_in&>(ours);
    const auto& t = reinterpret_cast<const sockaddr_in&>(theirs);
    return look_up({"/proc/net/tcp", proc_form(&t.sin_addr, 1, t.sin_port), proc_form(&o.sin_addr, 1, o.sin_port)});
  }
  if (ours.ss_family != AF_INET6) return std::nullopt;
  const auto& o = reinterpret_cast<const sockaddr_in6&>(ours);
  const auto& t = reinterpret_cast<const sockaddr_in6&>(theirs);
  if (auto found = look_up({"/proc/net/tcp6", proc_form(&t.sin6_addr, 4, t.sin6_port),
                            proc_form(&o.sin6_addr, 4, o.sin6_port)}))
    return found;
  if (!v4_mapped(t.sin6_addr) || !v4_mapped(o.sin6_addr)) return std::nullopt;
  return look_up({"/proc/net/tcp", proc_form(&t.sin6_addr.s6_addr[12], 1, t.sin6_port),
                  proc_form(&o.sin6_addr.s6_addr[12], 1, o.sin6_port)});
}

}  // namespace

std::optional<SocketPeer> socket_peer(int fd) {
  int domain = 0, type = 0;
  socklen_t size = sizeof domain;
  if (::getsockopt(fd, SOL_SOCKET, SO_DOMAIN, &domain, &size) != 0) return std::nullopt;
  size = sizeof type;
  if (::getsockopt(fd, SOL_SOCKET, SO_TYPE, &type, &size) != 0 || type != SOCK_STREAM) return std::nullopt;
  if (domain == AF_UNIX) {
    // (On a TCP socket the kernel answers SO_PEERCRED too, with the overflow uid: nobody.)
    ucred credentials{};
    size = sizeof credentials;
    if (::getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &credentials, &size) != 0 || size != sizeof credentials ||
        credentials.pid <= 0)
      return std::nullopt;
    return SocketPeer{credentials.uid, credentials.pid, std::nullopt};
  }
  if (domain == AF_INET || domain == AF_INET6) return tcp_peer(fd);
  return std::nullopt;
}

bool process_holds_socket(pid_t pid, ino_t inode) {
  const std::string folder = "/proc/" + std::to_string(pid) + "/fd";
  DIR* dir = ::opendir(folder.c_str());
  if (!dir) return false;
  const std::string wanted = "socket:[" + std::to_string(inode) + "]";
  bool found = false;
  char target[64];
  while (const dirent* entry = ::readdir(dir)) {
    if (entry->d_name[0] == '.') continue;
    const std::string link = folder + "/" + entry->d_name;
    const ssize_t n = ::readlink(link.c_str(), target, sizeof target - 1);
    if (n <= 0) continue;
    if (wanted == std::string_view(target, static_cast<std::size_t>(n))) {
      found = true;
      break;
    }
  }
  ::closedir(dir);
  return found;
}

}  // namespace rtm
