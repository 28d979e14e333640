// SPDX-License-Identifier: Apache-2.0
#include "arm/can/bus.h"
#include "arm/can/local_bus.h"

#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <algorithm>
#include <array>
#include <chrono>
#include <cstring>
#include <string>
#include <vector>

namespace rtm::can {

namespace {

std::string errno_text(int error) { return std::string(std::strerror(error)); }

[[noreturn]] void fail(const std::string& spec, const std::string& what, int error) {
  throw BusError("CAN bus '" + spec + "': " + what + ": " + errno_text(error));
}

timespec to_timespec(std::chrono::nanoseconds d) {
  if (d.count() < 0) d = std::chrono::nanoseconds(0);
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(d.count() / 1'000'000'000);
  ts.tv_nsec = static_cast<long>(d.count() % 1'000'000'000);
  return ts;
}

// Waits until fd is readable or the deadline passed; false on timeout.
bool wait_readable(int fd, std::chrono::steady_clock::time_point deadline, const std::string& spec) {
  for (;;) {
    const auto left = deadline - std::chrono::steady_clock::now();
    pollfd p{fd, POLLIN, 0};
    const timespec ts = to_timespec(std::chrono::duration_cast<std::chrono::nanoseconds>(left));
    const int n = ppoll(&p, 1, &ts, nullptr);
    if (n > 0) return true;
    if (n == 0) return false;
    if (errno != EINTR) fail(spec, "poll", errno);
  }
}

// A full transmit queue usually drains within a frame time or two (~0.1 ms at 1 Mbit/s): wait
// that long, bounded, before reporting the frame dropped. A real can0 has txqueuelen 10 by
// default; see docs/can-protocol.md.
constexpr auto kSendPatience = std::chrono::milliseconds(1);

bool wait_writable(int fd, std::chrono::steady_clock::time_point deadline) {
  const auto left = deadline - std::chrono::steady_clock::now();
  if (left <= std::chrono::steady_clock::duration::zero()) return false;
  pollfd p{fd, POLLOUT, 0};
  // ENOBUFS from a CAN qdisc does not always show in POLLOUT: poll at most 100 µs at a time.
  const auto slice = std::min<std::chrono::nanoseconds>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(left), std::chrono::microseconds(100));
  const timespec ts = to_timespec(slice);
  ppoll(&p, 1, &ts, nullptr);
  return true;
}

// Sending one datagram (a frame on CAN_RAW; 1 to kMaxFramesPerDatagram frames on the hub's
// SOCK_SEQPACKET). A full transmit queue is waited on for kSendPatience, then the datagram counts
// as dropped (false); any other error goes to fail_with(errno, call), which throws.
template <class Fail>
bool send_datagram(int fd, const void* data, std::size_t length, int flags, const Fail& fail_with) {
  const auto deadline = std::chrono::steady_clock::now() + kSendPatience;
  for (;;) {
    const ssize_t n = ::send(fd, data, length, flags | MSG_DONTWAIT);
    if (n == static_cast<ssize_t>(length)) return true;
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == ENOBUFS || errno == EAGAIN)) {
      if (wait_writable(fd, deadline)) continue;
      return false;
    }
    fail_with(n < 0 ? errno : EIO, "send");
  }
}

template <class Fail>
bool send_frame(int fd, const can_frame& frame, int flags, const Fail& fail_with) {
  return send_datagram(fd, &frame, sizeof frame, flags, fail_with);
}

// The same for several frames: sendmmsg, up to kBatchChunk per call, and what a full queue
// did not take one by one through send_frame(). Returns how many were queued.
template <class Fail>
std::size_t send_frames(int fd, std::span<const can_frame> frames, int flags, const Fail& fail_with) {
  constexpr std::size_t kBatchChunk = 16;
  std::size_t sent = 0;
  while (sent < frames.size()) {
    const std::size_t count = std::min(kBatchChunk, frames.size() - sent);
    mmsghdr messages[kBatchChunk]{};
    iovec parts[kBatchChunk];
    for (std::size_t i = 0; i < count; ++i) {
      parts[i].iov_base = const_cast<can_frame*>(&frames[sent + i]);
      parts[i].iov_len = sizeof(can_frame);
      messages[i].msg_hdr.msg_iov = &parts[i];
      messages[i].msg_hdr.msg_iovlen = 1;
    }
    const int n = ::sendmmsg(fd, messages, static_cast<unsigned>(count), flags | MSG_DONTWAIT);
    if (n < 0 && errno != EAGAIN && errno != ENOBUFS && errno != EINTR) fail_with(errno, "sendmmsg");
    if (n < static_cast<int>(count)) {  // the queue is full (or a signal came): the rest waits
      if (n > 0) sent += static_cast<std::size_t>(n);
      while (sent < frames.size() && send_frame(fd, frames[sent], flags, fail_with)) ++sent;
      return sent;
    }
    sent += count;
  }
  return sent;
}

class FdOwner {
 public:
  explicit FdOwner(int fd) : fd_(fd) {}
  ~FdOwner() {
    if (fd_ >= 0) ::close(fd_);
  }
  FdOwner(const FdOwner&) = delete;
  FdOwner& operator=(const FdOwner&) = delete;
  int get() const { return fd_; }
  int release() {
    const int fd = fd_;
    fd_ = -1;
    return fd;
  }

 private:
  int fd_;
};

// ---- SocketCAN ---------------------------------------------------------------------------

class SocketCanBus final : public Bus {
  // What a failed system call throws (send_frame, send_frames).
  auto failure() const {
    return [this](int error, const char* call) { fail(name_, call, error); };
  }

 public:
  SocketCanBus(std::string_view ifname, std::span<const FrameFilter> filters)
      : name_("socketcan:" + std::string(ifname)), fd_(open_socket(ifname, filters, name_)) {}

  bool send(const can_frame& frame) override { return send_frame(fd_.get(), frame, 0, failure()); }
  std::size_t send_batch(std::span<const can_frame> frames) override {
    return send_frames(fd_.get(), frames, 0, failure());
  }

  bool receive(can_frame& frame, std::int64_t timeout_ns) override {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::nanoseconds(timeout_ns);
    for (;;) {
      const ssize_t n = ::recv(fd_.get(), &frame, sizeof frame, MSG_DONTWAIT);
      if (n == static_cast<ssize_t>(sizeof frame)) return true;  // filters are in the kernel
      if (n >= 0) continue;  // a short read cannot happen on CAN_RAW; skip it anyway
      if (errno == EINTR) continue;
      if (errno != EAGAIN) fail(name_, "recv", errno);
      if (!wait_readable(fd_.get(), deadline, name_)) return false;
    }
  }

  // The kernel queues a frame to the host's other CAN sockets as it is sent.
  bool fence(std::int64_t) override { return true; }
  int pollable_fd() const override { return fd_.get(); }
  const std::string& name() const override { return name_; }

 private:
  static int open_socket(std::string_view ifname, std::span<const FrameFilter> filters,
                         const std::string& spec) {
    if (ifname.empty()) throw BusError("CAN bus '" + spec + "': no interface name after 'socketcan:'");
    if (ifname.size() >= IFNAMSIZ) {
      throw BusError("CAN bus '" + spec + "': interface name longer than " +
                     std::to_string(IFNAMSIZ - 1) + " characters");
    }
    const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
    if (fd < 0) {
      const int error = errno;
      if (error == EAFNOSUPPORT) {
        throw BusError("CAN bus '" + spec +
                       "': this kernel has no SocketCAN support (socket(AF_CAN) failed: " +
                       errno_text(error) +
                       "); use the user-space bus instead: run 'rtm-canhub <path>' and open "
                       "'local:<path>'");
      }
      fail(spec, "socket(PF_CAN, SOCK_RAW, CAN_RAW)", error);
    }
    FdOwner guard(fd);
    const std::string name(ifname);
    const unsigned index = ::if_nametoindex(name.c_str());
    if (index == 0) {
      const int error = errno;  // before the message is built: that allocates
      fail(spec, "no CAN interface '" + name + "' (create it, e.g. 'ip link add dev " + name +
                     " type vcan && ip link set up " + name + "')",
           error);
    }
    if (!filters.empty()) {
      std::vector<can_filter> kernel_filters;
      for (const auto& f : filters) kernel_filters.push_back(can_filter{f.id, f.mask});
      if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, kernel_filters.data(),
                       static_cast<socklen_t>(kernel_filters.size() * sizeof(can_filter))) != 0) {
        fail(spec, "setsockopt(CAN_RAW_FILTER)", errno);
      }
    }
    sockaddr_can address{};
    address.can_family = AF_CAN;
    address.can_ifindex = static_cast<int>(index);
    if (::bind(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
      fail(spec, "bind to interface '" + name + "'", errno);
    }
    return guard.release();
  }

  std::string name_;
  FdOwner fd_;
};

// ---- local bus endpoint ------------------------------------------------------------------

class LocalBus final : public Bus {
  // What a failed system call throws (send_frame, send_frames).
  auto failure() const {
    return [this](int error, const char* call) {
      if (error == EPIPE || error == ECONNRESET) throw BusError("CAN bus '" + name_ + "': the hub closed the connection");
      fail(name_, call, error);
    };
  }

 public:
  LocalBus(std::string_view path, std::span<const FrameFilter> filters)
      : name_("local:" + std::string(path)),
        filters_(filters.begin(), filters.end()),
        fd_(connect_hub(path, name_)) {
    for (std::size_t i = 0; i < kBatch; ++i) {  // the kernel writes only msg_len and msg_flags
      iov_[i] = {buffers_[i].data(), buffers_[i].size()};
      messages_[i].msg_hdr.msg_iov = &iov_[i];
      messages_[i].msg_hdr.msg_iovlen = 1;
    }
    tell_hub_the_filters();
  }
  LocalBus(const LocalBus&) = delete;
  LocalBus& operator=(const LocalBus&) = delete;

  bool send(const can_frame& frame) override { return send_frame(fd_.get(), frame, MSG_NOSIGNAL, failure()); }
  // A batch leaves as datagrams of up to kMaxFramesPerDatagram frames (one for a cycle's): the
  // hub is woken once, where a datagram per frame woke it once per frame.
  std::size_t send_batch(std::span<const can_frame> frames) override {
    std::size_t sent = 0;
    while (sent < frames.size()) {
      const std::size_t count = std::min(kMaxFramesPerDatagram, frames.size() - sent);
      if (!send_datagram(fd_.get(), frames.data() + sent, count * sizeof(can_frame), MSG_NOSIGNAL, failure())) break;
      sent += count;
    }
    return sent;
  }

  // The datagrams the hub queued for this endpoint are taken up to kBatch at a time (one
  // recvmmsg for a cycle's) and their frames handed out one by one; a frame that does not pass
  // the filters costs no system call of its own.
  bool receive(can_frame& frame, std::int64_t timeout_ns) override {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::nanoseconds(timeout_ns);
    for (;;) {
      while (next_ < taken_) {
        const can_frame& f = batch_[next_++];
        if (!passes(f, filters_)) continue;
        frame = f;
        return true;
      }
      if (!take_batch() && !wait_readable(fd_.get(), deadline, name_)) return false;
    }
  }

  // The hub answers after the round that read the fence has handed on every frame before it
  // (local_bus.h). Frames that come meanwhile are kept for receive(), as many as batch_ holds.
  bool fence(std::int64_t timeout_ns) override {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::nanoseconds(timeout_ns);
    if (::send(fd_.get(), kFenceMagic.data(), kFenceMagic.size(), MSG_NOSIGNAL) !=
        static_cast<ssize_t>(kFenceMagic.size()))
      failure()(errno, "send (a fence to the hub)");
    const std::uint64_t mine = ++fences_asked_;
    while (fences_answered_ < mine) {
      if (taken_ - next_ + kMaxFramesPerDatagram > batch_.size()) return false;  // no room to read on
      if (!take_batch() && !wait_readable(fd_.get(), deadline, name_)) return false;
    }
    return true;
  }

  int pollable_fd() const override { return fd_.get(); }
  const std::string& name() const override { return name_; }

 private:
  static int connect_hub(std::string_view path, const std::string& spec) {
    if (path.empty()) throw BusError("CAN bus '" + spec + "': no socket path after 'local:'");
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    if (path.size() >= sizeof address.sun_path) {
      throw BusError("CAN bus '" + spec + "': socket path longer than " +
                     std::to_string(sizeof address.sun_path - 1) + " bytes");
    }
    std::memcpy(address.sun_path, path.data(), path.size());
    const int fd = ::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
    if (fd < 0) fail(spec, "socket(AF_UNIX, SOCK_SEQPACKET)", errno);
    if (::connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
      const int error = errno;
      ::close(fd);
      fail(spec, "no hub listening at '" + std::string(path) + "' (start one: rtm-canhub " +
                     std::string(path) + ")",
           error);
    }
    return fd;
  }

  // The hub then copies this endpoint only the frames it wants and wakes it for no other
  // (local_bus.h); the filters here still apply, for a hub that does not know the message.
  void tell_hub_the_filters() {
    if (filters_.empty() || filters_.size() > kMaxFilters) return;
    std::array<unsigned char, kFilterMagic.size() + 8 * kMaxFilters> message{};
    std::memcpy(message.data(), kFilterMagic.data(), kFilterMagic.size());
    std::size_t length = kFilterMagic.size();
    for (const FrameFilter& f : filters_) {
      std::memcpy(message.data() + length, &f.id, 4);
      std::memcpy(message.data() + length + 4, &f.mask, 4);
      length += 8;
    }
    if (::send(fd_.get(), message.data(), length, MSG_NOSIGNAL) != static_cast<ssize_t>(length))
      fail(name_, "send (filters to the hub)", errno);
  }

  // Appends to batch_ the frames queued now (of whole, well-formed datagrams), after those not
  // handed out yet (none when receive() calls it); false when none was queued. Throws BusError
  // when the hub closed the connection.
  bool take_batch() {
    if (next_ > 0) {
      std::memmove(batch_.data(), batch_.data() + next_, (taken_ - next_) * sizeof(can_frame));
      taken_ -= next_;
      next_ = 0;
    }
    const unsigned room = static_cast<unsigned>(std::min(kBatch, (batch_.size() - taken_) / kMaxFramesPerDatagram));
    if (room == 0) return false;
    int n = -1;
    do {
      n = ::recvmmsg(fd_.get(), messages_.data(), room, MSG_DONTWAIT, nullptr);
    } while (n < 0 && errno == EINTR);
    if (n < 0) {
      if (errno == EAGAIN) return false;
      if (errno == ECONNRESET) throw BusError("CAN bus '" + name_ + "': the hub closed the connection");
      fail(name_, "recvmmsg", errno);
    }
    for (int i = 0; i < n; ++i) {
      const unsigned length = messages_[i].msg_len;
      if (length == 0) {  // the hub closed the connection (it never sends an empty datagram)
        if (taken_ > 0) return true;  // these first; the next take finds the close again
        throw BusError("CAN bus '" + name_ + "': the hub closed the connection");
      }
      if (length == kFenceMagic.size() && std::memcmp(buffers_[i].data(), kFenceMagic.data(), length) == 0) {
        ++fences_answered_;
        continue;
      }
      // A malformed datagram is dropped whole, as the hub drops one.
      const std::size_t frames = frames_in_datagram(buffers_[i].data(), length, messages_[i].msg_hdr.msg_flags);
      std::memcpy(&batch_[taken_], buffers_[i].data(), frames * sizeof(can_frame));
      taken_ += frames;
    }
    return true;
  }

  static constexpr std::size_t kBatch = 8;  // datagrams per recvmmsg, each up to kMaxFramesPerDatagram frames
  std::string name_;
  std::vector<FrameFilter> filters_;
  FdOwner fd_;
  std::array<can_frame, kBatch * kMaxFramesPerDatagram> batch_{};
  // recvmmsg's datagrams, one byte more than the largest each: MSG_TRUNC shows a longer one.
  std::array<std::array<unsigned char, kMaxFramesPerDatagram * sizeof(can_frame) + 1>, kBatch> buffers_{};
  std::array<iovec, kBatch> iov_{};
  std::array<mmsghdr, kBatch> messages_{};
  std::size_t next_ = 0;   // the next frame of batch_ to hand out
  std::size_t taken_ = 0;  // frames in batch_
  std::uint64_t fences_asked_ = 0;
  std::uint64_t fences_answered_ = 0;
};

}  // namespace

bool passes(const can_frame& frame, std::span<const FrameFilter> filters) noexcept {
  if (filters.empty()) return true;
  for (const auto& f : filters) {
    if ((frame.can_id & f.mask) == (f.id & f.mask)) return true;
  }
  return false;
}

std::unique_ptr<Bus> open_socketcan(std::string_view ifname, std::span<const FrameFilter> filters) {
  return std::make_unique<SocketCanBus>(ifname, filters);
}

std::unique_ptr<Bus> open_local(std::string_view hub_path, std::span<const FrameFilter> filters) {
  return std::make_unique<LocalBus>(hub_path, filters);
}

std::unique_ptr<Bus> open_bus(std::string_view spec, std::span<const FrameFilter> filters) {
  const auto colon = spec.find(':');
  const std::string_view scheme = colon == std::string_view::npos ? spec : spec.substr(0, colon);
  const std::string_view rest = colon == std::string_view::npos ? std::string_view{} : spec.substr(colon + 1);
  if (colon != std::string_view::npos && scheme == "socketcan") return open_socketcan(rest, filters);
  if (colon != std::string_view::npos && scheme == "local") return open_local(rest, filters);
  throw BusError("CAN bus '" + std::string(spec) +
                 "': unknown bus spec; expected 'socketcan:<interface>' (e.g. socketcan:vcan0) "
                 "or 'local:<socket path>' (a hub started with rtm-canhub)");
}

}  // namespace rtm::can
