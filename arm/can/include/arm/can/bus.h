// SPDX-License-Identifier: Apache-2.0
// CAN frame transports: Linux SocketCAN and the user-space local bus, behind one interface.
//
// Everything above the transport (codec, CANopen master, sensor listener, the simulator's
// device side) sees only `Bus`: the same `struct can_frame` bytes travel over a SocketCAN raw
// socket (`socketcan:vcan0`, `socketcan:can0`) or over the user-space hub (`local:/tmp/pa10.bus`).
// Both deliver a frame to every OTHER endpoint and never back to its sender, as vcan does.
#pragma once

#include <linux/can.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>

namespace rtm::can {

// ---- errors ------------------------------------------------------------------------------

// A transport could not be opened or failed; the message names the bus spec and the cause.
class BusError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// ---- filters -----------------------------------------------------------------------------

// Accept a frame when (frame.can_id & mask) == (id & mask), as SocketCAN's `struct can_filter`.
// An empty filter list accepts every frame. The local bus applies the same rule in user space.
struct FrameFilter {
  canid_t id = 0;
  canid_t mask = 0;
};

// ---- the transport -----------------------------------------------------------------------

class Bus {
 public:
  virtual ~Bus() = default;
  Bus() = default;
  Bus(const Bus&) = delete;
  Bus& operator=(const Bus&) = delete;

  // Queues one frame. Returns false when the transmit queue stayed full for 1 ms and the frame
  // was dropped (what an overloaded CAN controller does); throws BusError on a hard failure
  // (interface gone, hub gone). Blocks at most that 1 ms.
  virtual bool send(const can_frame& frame) = 0;

  // Queues frames in order, in as few system calls as the transport allows (sendmmsg: one
  // for a cycle's RPDOs and SYNC), so the sender hands a whole cycle to the bus at once and a
  // receiver woken by the first frame cannot delay the rest. Returns how many were queued: a
  // frame that finds the transmit queue full waits as in send(), and the frames from the
  // first one dropped on are not sent. Throws BusError as send(). No allocation.
  virtual std::size_t send_batch(std::span<const can_frame> frames) = 0;

  // Waits up to `timeout_ns` nanoseconds for one frame (0 = just poll). Returns false on
  // timeout. Frames not passing the filters are skipped without counting against the caller.
  // Throws BusError when the transport fails (e.g. the hub closed the connection).
  virtual bool receive(can_frame& frame, std::int64_t timeout_ns) = 0;

  // Returns true once every frame this endpoint sent before the call is in every other
  // endpoint's receive queue, so that what one of them does next sees them: the lock-step of
  // tests that send a frame and then step a master, instead of sleeping. The local bus asks
  // its hub, which answers after it has handed those frames on; frames that come for this
  // endpoint meanwhile stay queued for receive(). SocketCAN queues a frame to the host's
  // other sockets as it is sent: true at once. False when no answer came within timeout_ns.
  virtual bool fence(std::int64_t timeout_ns) = 0;

  // A file descriptor that poll()s readable (POLLIN) when receive() may return a frame
  // without waiting; lets one thread wait on several buses. A readable fd can still yield no
  // frame (a filtered-out or malformed datagram): call receive() with timeout 0.
  virtual int pollable_fd() const = 0;

  // The spec the bus was opened with, e.g. "socketcan:vcan0", for messages.
  virtual const std::string& name() const = 0;
};

// ---- opening a bus by spec ---------------------------------------------------------------

// Opens "socketcan:<ifname>" (raw CAN socket bound to that interface) or "local:<path>"
// (an endpoint of the LocalHub listening at <path>). Throws BusError naming the spec for an
// unknown scheme, an empty interface/path, a missing interface or hub, and - when the kernel
// has no CAN support (socket(AF_CAN) fails with EAFNOSUPPORT) - says so and suggests
// "local:<path>" with rtm-canhub instead.
std::unique_ptr<Bus> open_bus(std::string_view spec, std::span<const FrameFilter> filters = {});

// The two transports directly (open_bus dispatches to these).
std::unique_ptr<Bus> open_socketcan(std::string_view ifname,
                                    std::span<const FrameFilter> filters = {});
std::unique_ptr<Bus> open_local(std::string_view hub_path,
                                std::span<const FrameFilter> filters = {});

// True when frame passes the filter list (empty list: always).
bool passes(const can_frame& frame, std::span<const FrameFilter> filters) noexcept;

}  // namespace rtm::can
