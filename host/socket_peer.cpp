// SPDX-License-Identifier: Apache-2.0
#include "host/socket_peer.h"

#include <arpa/inet.h>
#include <linux/inet_diag.h>
#include <linux/netlink.h>
#include <linux/sock_diag.h>
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

// One end of a TCP connection: its address (4 or 16 bytes) and port, as the socket calls give
// them (network order).
struct End {
  int family = AF_INET;
  const void* address = nullptr;
  std::uint16_t port = 0;
};

// The socket whose own end is `own` and whose other end is `other`, asked of the kernel for that
// one socket (NETLINK_SOCK_DIAG without NLM_F_DUMP: an exact look-up, what `ss` uses; constant
// time, no privilege). nullopt when there is no such socket or the kernel does not answer.
std::optional<SocketPeer> ask_kernel(const End& own, const End& other) {
  struct {
    nlmsghdr header;
    inet_diag_req_v2 request;
  } ask{};
  ask.header.nlmsg_len = sizeof ask;
  ask.header.nlmsg_type = SOCK_DIAG_BY_FAMILY;
  ask.header.nlmsg_flags = NLM_F_REQUEST;  // no NLM_F_DUMP: the one socket, not the table
  ask.request.sdiag_family = static_cast<std::uint8_t>(own.family);
  ask.request.sdiag_protocol = IPPROTO_TCP;
  ask.request.idiag_states = ~0U;
  ask.request.id.idiag_sport = own.port;
  ask.request.id.idiag_dport = other.port;
  const std::size_t size = own.family == AF_INET ? 4 : 16;
  std::memcpy(ask.request.id.idiag_src, own.address, size);
  std::memcpy(ask.request.id.idiag_dst, other.address, size);
  ask.request.id.idiag_cookie[0] = ask.request.id.idiag_cookie[1] = INET_DIAG_NOCOOKIE;
  const int fd = ::socket(AF_NETLINK, SOCK_DGRAM | SOCK_CLOEXEC, NETLINK_SOCK_DIAG);
  if (fd < 0) return std::nullopt;
  const timeval wait{0, 200'000};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &wait, sizeof wait);
  sockaddr_nl kernel{};
  kernel.nl_family = AF_NETLINK;
  alignas(nlmsghdr) char answer[8192];
  ssize_t n = -1;
  if (::sendto(fd, &ask, sizeof ask, 0, reinterpret_cast<sockaddr*>(&kernel), sizeof kernel) == sizeof ask)
    n = ::recv(fd, answer, sizeof answer, 0);
  ::close(fd);
  const auto* reply = reinterpret_cast<const nlmsghdr*>(answer);
  if (n < static_cast<ssize_t>(NLMSG_LENGTH(sizeof(inet_diag_msg))) || !NLMSG_OK(reply, static_cast<unsigned>(n)) ||
      reply->nlmsg_type != SOCK_DIAG_BY_FAMILY)
    return std::nullopt;  // NLMSG_ERROR: no such socket
  const auto* found = static_cast<const inet_diag_msg*>(NLMSG_DATA(reply));
  SocketPeer peer;
  peer.uid = found->idiag_uid;
  peer.inode = found->idiag_inode;
  return peer;
}

// The same socket found in /proc/net/tcp or tcp6 (the whole table read: only where the kernel
// does not answer the look-up above).
std::optional<SocketPeer> read_table(const End& own, const End& other) {
  const std::size_t words = own.family == AF_INET ? 1 : 4;
  const std::string table = own.family == AF_INET ? "/proc/net/tcp" : "/proc/net/tcp6";
  const std::string own_text = proc_form(own.address, words, own.port);
  const std::string other_text = proc_form(other.address, words, other.port);
  std::ifstream in(table);
  std::string line;
  std::getline(in, line);  // the header
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string slot, local, remote, state, queues, timer, retransmits, uid, timeout, inode;
    if (!(fields >> slot >> local >> remote >> state >> queues >> timer >> retransmits >> uid >> timeout >> inode))
      continue;
    if (local != own_text || remote != other_text) continue;
    SocketPeer peer;
    peer.uid = static_cast<uid_t>(std::stoul(uid));
    peer.inode = static_cast<ino_t>(std::stoull(inode));
    return peer;
  }
  return std::nullopt;
}

std::optional<SocketPeer> find_socket(const End& own, const End& other) {
  if (auto found = ask_kernel(own, other)) return found;
  return read_table(own, other);
}

std::optional<SocketPeer> tcp_peer(int fd) {
  sockaddr_storage ours{}, theirs{};
  socklen_t our_size = sizeof ours, their_size = sizeof theirs;
  if (::getsockname(fd, reinterpret_cast<sockaddr*>(&ours), &our_size) != 0 ||
      ::getpeername(fd, reinterpret_cast<sockaddr*>(&theirs), &their_size) != 0 || ours.ss_family != theirs.ss_family)
    return std::nullopt;
  // The peer's socket: its own end is our other end.
  if (ours.ss_family == AF_INET) {
    const auto& o = reinterpret_cast<const sockaddr_in&>(ours);
    const auto& t = reinterpret_cast<const sockaddr_in&>(theirs);
    return find_socket({AF_INET, &t.sin_addr, t.sin_port}, {AF_INET, &o.sin_addr, o.sin_port});
  }
  if (ours.ss_family != AF_INET6) return std::nullopt;
  const auto& o = reinterpret_cast<const sockaddr_in6&>(ours);
  const auto& t = reinterpret_cast<const sockaddr_in6&>(theirs);
  if (auto found = find_socket({AF_INET6, &t.sin6_addr, t.sin6_port}, {AF_INET6, &o.sin6_addr, o.sin6_port}))
    return found;
  if (!IN6_IS_ADDR_V4MAPPED(&t.sin6_addr) || !IN6_IS_ADDR_V4MAPPED(&o.sin6_addr)) return std::nullopt;
  return find_socket({AF_INET, &t.sin6_addr.s6_addr[12], t.sin6_port},  // an IPv4 peer
                     {AF_INET, &o.sin6_addr.s6_addr[12], o.sin6_port});
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
