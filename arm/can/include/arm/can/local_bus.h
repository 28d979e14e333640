// SPDX-License-Identifier: Apache-2.0
// The user-space CAN bus: a hub that forwards every frame to every other endpoint.
//
// For hosts without SocketCAN (this project's CI kernels) and for tests. The hub listens on a
// Unix SOCK_SEQPACKET socket; each connection is one endpoint; each datagram is 1 to
// kMaxFramesPerDatagram whole `struct can_frame`s (16 bytes each), in bus order: a sender's batch
// (a cycle's RPDOs and SYNC) goes as one datagram, and the hub hands each endpoint a round's
// frames as one, so a cycle wakes each receiver once rather than once per frame. A datagram that
// is not whole frames, holds more than kMaxFramesPerDatagram, or has a frame with can_dlc > 8 is
// dropped whole and counted. An endpoint that cannot keep up loses frames (counted), like a CAN
// controller whose receive FIFO overflows: the hub never blocks on a slow endpoint. Endpoints
// connect with `open_bus("local:<path>")`; the `rtm-canhub <path>` executable runs a hub as a
// process.
//
// An endpoint may tell the hub which frames it wants, as a SocketCAN socket tells the kernel
// (CAN_RAW_FILTER): one datagram of kFilterMagic (8 bytes) and then up to kMaxFilters pairs of
// little-endian u32 (id, mask). The hub then neither copies it other frames nor wakes it for
// them; a new such datagram replaces the list, none (the default) means every frame. The magic
// reads as a frame with can_dlc 'A' (65), so a hub that does not know it drops it as malformed
// and the endpoint's own filtering still holds. open_local() sends its filters so.
//
// An endpoint may ask the hub to answer once everything it sent before has been handed on
// (Bus::fence): one datagram of kFenceMagic; the hub sends the same 8 bytes back to it after
// the round in which it read them has delivered every frame taken so far. A hub that does not
// know it drops it as malformed (can_dlc 'A'), and the fence times out.
#pragma once

#include <poll.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <thread>
#include <vector>

namespace rtm::can {

inline constexpr std::array<unsigned char, 8> kFilterMagic{'R', 'T', 'M', 'C', 'A', 'N', 'F', '1'};
inline constexpr std::array<unsigned char, 8> kFenceMagic{'R', 'T', 'M', 'C', 'A', 'N', 'B', '1'};
inline constexpr std::size_t kMaxFilters = 32;
inline constexpr std::size_t kMaxFramesPerDatagram = 32;

// The frames a received datagram of this bus carries: 1 to kMaxFramesPerDatagram whole frames,
// not truncated (`msg_flags` from recvmsg without MSG_TRUNC) and each with can_dlc <= 8; 0 for
// any other (malformed: dropped whole, by the hub and by an endpoint alike).
std::size_t frames_in_datagram(const unsigned char* data, std::size_t length, int msg_flags) noexcept;

class LocalHub {
 public:
  struct Counters {
    std::uint64_t frames_forwarded = 0;     // frames accepted from endpoints
    std::uint64_t deliveries = 0;           // frame copies written to other endpoints
    std::uint64_t deliveries_dropped = 0;   // receiver's socket buffer was full
    std::uint64_t datagrams_malformed = 0;  // not whole frames, too many, or can_dlc > 8: dropped
    std::uint64_t endpoints_connected = 0;  // total connections accepted
    std::uint64_t endpoints_closed = 0;     // total connections that went away
    std::uint64_t endpoints_refused = 0;    // connections closed at once: kMaxEndpoints reached
    std::uint64_t filters_set = 0;          // filter lists endpoints sent
    std::uint64_t frames_filtered = 0;      // frame copies an endpoint's filters kept from it
    std::uint64_t fences_answered = 0;      // Bus::fence requests answered
  };
  // Endpoints the hub serves at once (a bus has a master, the nodes, a few listeners).
  static constexpr std::size_t kMaxEndpoints = 32;

  // Who runs the hub's poll loop: a thread of its own, or the loop of the program that hosts
  // it, which polls the hub's descriptors with its own and calls relay() (pa10-sim: a bus
  // round then costs it no wake-up of a second thread).
  enum class Driver { own_thread, caller };

  // Binds and listens at `socket_path` (an existing stale socket file there is replaced;
  // anything else there is an error), then forwards on its own thread (Driver::own_thread) or
  // when the caller says (Driver::caller). Throws BusError with the path and the cause.
  explicit LocalHub(std::string socket_path, Driver driver = Driver::own_thread);
  ~LocalHub();  // stop()
  LocalHub(const LocalHub&) = delete;
  LocalHub& operator=(const LocalHub&) = delete;

  // Stops the thread, closes every endpoint (they see the connection closed) and removes the
  // socket file. Idempotent.
  void stop();

  const std::string& path() const { return socket_path_; }
  std::size_t endpoint_count() const;
  Counters counters() const;

  // Driver::caller, from one thread. add_poll_fds() appends the hub's descriptors (POLLIN)
  // to the caller's poll set; after the poll, relay() takes that part of the set, accepts new
  // endpoints, relays every frame that came to every other endpoint and lets closed ones go,
  // as the hub's own thread does in a round. Returns how many frames it relayed. Nothing is
  // allocated once the set's capacity covers the hub's descriptors (kMaxEndpoints + 1).
  void add_poll_fds(std::vector<pollfd>& fds) const;
  std::size_t relay(std::span<const pollfd> polled);

 private:
  class Relay;  // one poll round's frames, taken and handed on in batches
  void run();
  void publish_counters(bool endpoints_changed);

  std::string socket_path_;
  int listen_fd_ = -1;
  int wake_fd_ = -1;  // eventfd: stop() wakes the poll loop
  std::atomic<bool> stopping_{false};
  mutable std::mutex counters_mutex_;
  Counters counters_;
  std::size_t endpoint_count_ = 0;
  // The poll loop's state, touched only by whoever runs it (the thread, or relay()'s caller).
  std::vector<int> endpoints_;
  std::vector<int> closed_;
  std::unique_ptr<Relay> relay_;
  Counters local_{};  // accumulated per round, then published to counters_
  std::thread thread_;
};

}  // namespace rtm::can
