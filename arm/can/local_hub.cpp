// SPDX-License-Identifier: Apache-2.0
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstddef>
#include <cstring>
#include <memory>
#include <span>
#include <unordered_map>
#include <vector>

#include "arm/can/bus.h"
#include "arm/can/local_bus.h"

namespace rtm::can {

namespace {

[[noreturn]] void fail(const std::string& path, const std::string& what, int error) {
  throw BusError("CAN hub at '" + path + "': " + what + ": " + std::strerror(error));
}

sockaddr_un unix_address(const std::string& path) {
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  if (path.empty()) throw BusError("CAN hub: empty socket path");
  if (path.size() >= sizeof address.sun_path) {
    throw BusError("CAN hub at '" + path + "': socket path longer than " +
                   std::to_string(sizeof address.sun_path - 1) + " bytes");
  }
  std::memcpy(address.sun_path, path.data(), path.size());
  return address;
}

// A socket file left by a hub that died is replaced; a live hub or a non-socket is an error.
void remove_stale_socket(const std::string& path, const sockaddr_un& address) {
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0) return;  // nothing there
  if (!S_ISSOCK(st.st_mode)) {
    throw BusError("CAN hub at '" + path + "': the path exists and is not a socket");
  }
  const int probe = ::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
  if (probe < 0) fail(path, "socket", errno);
  const int rc = ::connect(probe, reinterpret_cast<const sockaddr*>(&address), sizeof address);
  const int error = errno;
  ::close(probe);
  if (rc == 0) throw BusError("CAN hub at '" + path + "': another hub is already listening there");
  if (error != ECONNREFUSED) fail(path, "probing the existing socket", error);
  ::unlink(path.c_str());
}

// Lets a receiver fall behind by a few hundred frames before its copies are dropped.
constexpr int kEndpointSendBuffer_bytes = 1 << 20;

}  // namespace

LocalHub::LocalHub(std::string socket_path, Driver driver) : socket_path_(std::move(socket_path)) {
  const sockaddr_un address = unix_address(socket_path_);
  remove_stale_socket(socket_path_, address);
  listen_fd_ = ::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (listen_fd_ < 0) fail(socket_path_, "socket(AF_UNIX, SOCK_SEQPACKET)", errno);
  // The socket stands for the bus cable: only this user may plug into it (bound with umask
  // 077, so it is never open to others, not even for an instant).
  const mode_t old_mask = ::umask(077);
  const int bound = ::bind(listen_fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address);
  const int bind_error = errno;
  ::umask(old_mask);
  if (bound != 0 || ::listen(listen_fd_, 64) != 0) {
    const int error = bound != 0 ? bind_error : errno;
    ::close(listen_fd_);
    fail(socket_path_, "bind/listen", error);
  }
  wake_fd_ = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (wake_fd_ < 0) {
    const int error = errno;
    ::close(listen_fd_);
    ::unlink(socket_path_.c_str());
    fail(socket_path_, "eventfd", error);
  }
  relay_ = std::make_unique<Relay>();  // some 80 KiB of round buffers, made once
  endpoints_.reserve(kMaxEndpoints);
  closed_.reserve(kMaxEndpoints);
  if (driver == Driver::own_thread) thread_ = std::thread([this] { run(); });
}

LocalHub::~LocalHub() { stop(); }

void LocalHub::stop() {
  if (stopping_.exchange(true)) return;
  const std::uint64_t one = 1;
  [[maybe_unused]] const ssize_t n = ::write(wake_fd_, &one, sizeof one);
  if (thread_.joinable()) thread_.join();
  for (int fd : endpoints_) ::close(fd);  // they see the connection closed
  endpoints_.clear();
  {
    std::lock_guard lock(counters_mutex_);
    endpoint_count_ = 0;
  }
  ::close(listen_fd_);
  ::close(wake_fd_);
  ::unlink(socket_path_.c_str());
}

std::size_t LocalHub::endpoint_count() const {
  std::lock_guard lock(counters_mutex_);
  return endpoint_count_;
}

LocalHub::Counters LocalHub::counters() const {
  std::lock_guard lock(counters_mutex_);
  return counters_;
}

// One poll round's frames: taken from every endpoint that has some in one recvmmsg per 32
// datagrams, then handed to each other endpoint as datagrams of up to kMaxFramesPerDatagram
// frames (gathered from the round, not copied), in one sendmmsg. A cycle's frames come as one
// datagram (a sender's batch) and leave as one, so each receiver is woken once per round, where
// a datagram per frame woke it (and cost its sender the wake-up) once per frame.
class LocalHub::Relay {
 public:
  static constexpr std::size_t kChunk = 32;          // datagrams per recvmmsg / sendmmsg
  static constexpr std::size_t kRoundFrames = 1024;  // per round; the rest wait for the next poll

  Relay() {  // the kernel writes only msg_len and msg_flags: the headers are set up once
    for (std::size_t i = 0; i < kChunk; ++i) {
      in_iov_[i] = {in_buffers_[i].data(), in_buffers_[i].size()};
      in_[i].msg_hdr.msg_iov = &in_iov_[i];
      in_[i].msg_hdr.msg_iovlen = 1;
    }
  }
  Relay(const Relay&) = delete;
  Relay& operator=(const Relay&) = delete;

  void clear() {
    count_ = 0;
    fences_ = 0;
  }
  std::size_t size() const { return count_; }  // frames taken this round
  void forget(int endpoint) { filters_.erase(endpoint); }  // it closed

  // Takes what `from` has queued, up to the round's room; false when `from` closed (or its
  // connection broke).
  bool take_from(int from, Counters& counters) {
    for (;;) {
      // Datagrams that surely fit, each being up to kMaxFramesPerDatagram frames.
      const std::size_t room = std::min(kChunk, (kRoundFrames - count_) / kMaxFramesPerDatagram);
      if (room == 0) return true;  // poll is level-triggered: the rest come next round
      const int n = ::recvmmsg(from, in_.data(), static_cast<unsigned>(room), MSG_DONTWAIT, nullptr);
      if (n < 0 && errno == EINTR) continue;
      if (n < 0 && errno == EAGAIN) return true;
      if (n <= 0) return false;  // a reset connection
      for (int i = 0; i < n; ++i) {
        const unsigned length = in_[i].msg_len;
        if (length == 0) return false;  // orderly close (no endpoint sends an empty datagram)
        if (take_filters(from, in_buffers_[i].data(), length, in_[i].msg_hdr.msg_flags, counters)) continue;
        if (length == kFenceMagic.size() && std::memcmp(in_buffers_[i].data(), kFenceMagic.data(), length) == 0) {
          if (fences_ < fencing_.size()) fencing_[fences_++] = from;  // answered after this round's delivery
          continue;
        }
        const std::size_t frames = frames_in_datagram(in_buffers_[i].data(), length, in_[i].msg_hdr.msg_flags);
        if (frames == 0) {  // not whole frames, too many, or one with can_dlc > 8: dropped whole
          ++counters.datagrams_malformed;
          continue;
        }
        std::memcpy(&frames_[count_], in_buffers_[i].data(), frames * sizeof(can_frame));
        for (std::size_t k = count_; k < count_ + frames; ++k) {
          sources_[k] = from;
          out_iov_[k] = {&frames_[k], sizeof(can_frame)};
        }
        count_ += frames;
        counters.frames_forwarded += frames;
      }
      if (static_cast<std::size_t>(n) < room) return true;  // drained
    }
  }

  // Gives every frame of the round to every endpoint but its sender, in the round's order, as
  // datagrams of up to kMaxFramesPerDatagram frames. A receiver whose socket buffer is full
  // loses the rest of the round (counted); a broken one shows up as POLLHUP/POLLERR on its own
  // descriptor.
  void deliver(const std::vector<int>& endpoints, Counters& counters) {
    for (int to : endpoints) {
      const auto wanted = filters_.find(to);
      const std::span<const FrameFilter> filters =
          wanted == filters_.end() ? std::span<const FrameFilter>{} : std::span<const FrameFilter>(wanted->second);
      std::size_t mine = 0;
      for (std::size_t i = 0; i < count_; ++i) {
        if (sources_[i] == to) continue;
        if (!passes(frames_[i], filters)) {
          ++counters.frames_filtered;  // neither copied nor woken for
          continue;
        }
        gather_[mine++] = out_iov_[i];
      }
      // Datagram d is frames [d * kMaxFramesPerDatagram, ...) of this endpoint's.
      const std::size_t datagrams = (mine + kMaxFramesPerDatagram - 1) / kMaxFramesPerDatagram;
      for (std::size_t d = 0; d < datagrams; ++d) {
        out_[d].msg_hdr.msg_iov = &gather_[d * kMaxFramesPerDatagram];
        out_[d].msg_hdr.msg_iovlen = std::min(kMaxFramesPerDatagram, mine - d * kMaxFramesPerDatagram);
      }
      std::size_t done = 0;  // datagrams
      while (done < datagrams) {
        const int n = ::sendmmsg(to, &out_[done], static_cast<unsigned>(datagrams - done), MSG_DONTWAIT | MSG_NOSIGNAL);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) {
          if (errno == EAGAIN || errno == ENOBUFS) counters.deliveries_dropped += mine - done * kMaxFramesPerDatagram;
          break;
        }
        done += static_cast<std::size_t>(n);
      }
      counters.deliveries += std::min(mine, done * kMaxFramesPerDatagram);
    }
    // Everything taken before each fence is in its receivers' queues now: answer it.
    for (std::size_t f = 0; f < fences_; ++f) {
      if (::send(fencing_[f], kFenceMagic.data(), kFenceMagic.size(), MSG_DONTWAIT | MSG_NOSIGNAL) ==
          static_cast<ssize_t>(kFenceMagic.size()))
        ++counters.fences_answered;
    }
  }

 private:
  // A filter list (local_bus.h: kFilterMagic, then (id, mask) pairs): kept for `from`; true
  // when the datagram was one.
  bool take_filters(int from, const unsigned char* data, unsigned length, int flags, Counters& counters) {
    if ((flags & MSG_TRUNC) != 0 || length < kFilterMagic.size() || (length - kFilterMagic.size()) % 8 != 0) return false;
    if (std::memcmp(data, kFilterMagic.data(), kFilterMagic.size()) != 0) return false;
    std::vector<FrameFilter>& list = filters_[from];
    list.clear();
    for (unsigned at = kFilterMagic.size(); at + 8 <= length; at += 8) {
      FrameFilter f;
      std::memcpy(&f.id, data + at, 4);
      std::memcpy(&f.mask, data + at + 4, 4);
      list.push_back(f);
    }
    if (list.empty()) filters_.erase(from);  // an empty list: every frame again
    ++counters.filters_set;
    return true;
  }

  static constexpr std::size_t kLargestDatagram =
      std::max(kFilterMagic.size() + 8 * kMaxFilters, kMaxFramesPerDatagram * sizeof(can_frame));
  static_assert(kRoundFrames / kMaxFramesPerDatagram <= kChunk, "a full round fits out_");
  std::array<can_frame, kRoundFrames> frames_{};
  std::array<int, kRoundFrames> sources_{};
  std::array<iovec, kRoundFrames> out_iov_{};
  std::array<iovec, kRoundFrames> gather_{};  // one endpoint's frames, in order
  std::array<mmsghdr, kChunk> out_{};
  // One byte more than the largest datagram: a longer one shows as MSG_TRUNC.
  std::array<std::array<unsigned char, kLargestDatagram + 1>, kChunk> in_buffers_{};
  std::unordered_map<int, std::vector<FrameFilter>> filters_;  // by endpoint; none: every frame
  std::array<iovec, kChunk> in_iov_{};
  std::array<mmsghdr, kChunk> in_{};
  std::size_t count_ = 0;
  std::array<int, kChunk * 4> fencing_{};  // endpoints that asked for a fence this round
  std::size_t fences_ = 0;
};

std::size_t frames_in_datagram(const unsigned char* data, std::size_t length, int msg_flags) noexcept {
  if ((msg_flags & MSG_TRUNC) != 0 || length == 0 || length % sizeof(can_frame) != 0) return 0;
  const std::size_t frames = length / sizeof(can_frame);
  if (frames > kMaxFramesPerDatagram) return 0;
  for (std::size_t k = 0; k < frames; ++k)
    if (data[k * sizeof(can_frame) + offsetof(can_frame, can_dlc)] > CAN_MAX_DLEN) return 0;
  return frames;
}

void LocalHub::add_poll_fds(std::vector<pollfd>& fds) const {
  fds.push_back({listen_fd_, POLLIN, 0});
  for (int fd : endpoints_) fds.push_back({fd, POLLIN, 0});
}

std::size_t LocalHub::relay(std::span<const pollfd> polled) {
  // A round of the host's poll that none of the hub's descriptors woke: nothing to do.
  if (std::none_of(polled.begin(), polled.end(), [](const pollfd& p) { return p.revents != 0; })) return 0;
  bool changed = false;
  closed_.clear();
  relay_->clear();
  for (const pollfd& p : polled) {
    if (p.revents == 0) continue;
    if (p.fd != listen_fd_) {
      if (!relay_->take_from(p.fd, local_)) closed_.push_back(p.fd);
      continue;
    }
    for (;;) {
      const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC | SOCK_NONBLOCK);
      if (fd < 0) break;
      if (endpoints_.size() >= kMaxEndpoints) {
        // Every frame is copied to every endpoint: their number bounds the hub's work per
        // frame (and the simulator's, on the same CPU). One more is closed at once.
        ::close(fd);
        ++local_.endpoints_refused;
        continue;
      }
      ::setsockopt(fd, SOL_SOCKET, SO_SNDBUF, &kEndpointSendBuffer_bytes, sizeof kEndpointSendBuffer_bytes);
      endpoints_.push_back(fd);
      ++local_.endpoints_connected;
      changed = true;
    }
  }
  const std::size_t relayed = relay_->size();
  relay_->deliver(endpoints_, local_);
  for (int fd : closed_) {
    relay_->forget(fd);
    ::close(fd);
    endpoints_.erase(std::find(endpoints_.begin(), endpoints_.end(), fd));
    ++local_.endpoints_closed;
    changed = true;
  }
  publish_counters(changed);
  return relayed;
}

void LocalHub::publish_counters(bool endpoints_changed) {
  std::lock_guard lock(counters_mutex_);
  counters_ = local_;
  if (endpoints_changed) endpoint_count_ = endpoints_.size();
}

void LocalHub::run() {
  // fds[0] = wake, then the hub's own (add_poll_fds), made again after each round.
  std::vector<pollfd> fds;
  fds.reserve(kMaxEndpoints + 2);
  while (!stopping_.load()) {
    fds.clear();
    fds.push_back({wake_fd_, POLLIN, 0});
    add_poll_fds(fds);
    const int n = ::poll(fds.data(), fds.size(), -1);
    if (n < 0) {
      if (errno == EINTR) continue;
      break;  // poll on our own descriptors cannot fail otherwise
    }
    if (fds[0].revents != 0) break;
    relay(std::span<const pollfd>(fds).subspan(1));
  }
}

}  // namespace rtm::can
