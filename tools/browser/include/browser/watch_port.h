// SPDX-License-Identifier: Apache-2.0
// The temporary InPort `rtm watch` subscribes: takes every datum of the watched port's type
// into a bounded queue the display drains. Implements RTM::InPortEx so the publisher can name
// it ("rtm-watch-<pid>.in") and report how many data it dropped for it, InPortOrdered so that
// what it shows is in the order written, and InPortShm so that a publisher on this host hands
// it its shared-memory ring: then no call is made per datum, and drain() takes what the ring
// holds every kRingPollMs (a few wake-ups a second instead of one per datum, and nothing a
// slow display can hold the publisher up with).
#pragma once

#include <RTM.hh>
#include <RTMExt.hh>

#include "rt/shm_ring.h"
#include "rt/shm_segment.h"
#include "rtm/orb.h"
#include "rtm/ring_types.h"
#include "rtm/sender_order.h"

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace rtm::cli {

class WatchPort final : public virtual POA_RTM::InPortShm {
 public:
  WatchPort(std::string owner, CORBA::TypeCode_ptr type, std::size_t capacity);

  // RTM::InPort / RTM::InPortEx
  void put(const CORBA::Any& value) override;
  void push(const CORBA::Any& value) override;
  void put_in_order(const CORBA::Any& value, CORBA::ULongLong sender, CORBA::ULongLong seq) override;
  void push_in_order(const CORBA::Any& value, CORBA::ULongLong sender, CORBA::ULongLong seq) override;
  char* name() override;
  CORBA::TypeCode_ptr port_type() override;
  char* owner() override;
  RTM::PortCounters counters() override;
  char* last_error() override;
  RTM::PortDescription* describe() override;  // "rtm watch display", no elements
  void admit_writer() override {}              // the access screen (host/access.h) answers
  char* reader_policy() override;               // "fifo:<capacity>": every datum, in order
  // RTM::InPortShm: reads the publisher's ring from now on (false with why: another host or
  // network namespace, a type this tool has no plain layout of, a segment it cannot map).
  CORBA::Boolean attach_ring(const char* segment, const char* host, CORBA::ULongLong type_id, CORBA::Long writer_pid,
                             CORBA::ULongLong writer_start, CORBA::String_out why) override;
  CORBA::Boolean detach_ring(const char* segment) override;  // takes what it still holds first

  // How often drain() looks at an attached ring while no put wakes it; the ring keeps
  // 256 data or more (a half second at 500 Hz), so a display this late loses nothing.
  static constexpr std::chrono::milliseconds kRingPollMs{20};

  // Waits up to timeout for data; moves what arrived into out. Returns false on timeout.
  bool drain(std::vector<CORBA::Any>& out, std::chrono::milliseconds timeout);

  std::uint64_t received() const;
  std::uint64_t overflowed() const;  // lost here because the display fell behind
  std::uint64_t late() const;        // dropped: arrived after a later datum of its sender
  std::uint64_t rejected() const;    // wrong type
  std::uint64_t shared_memory() const;  // of received: taken from the publisher's ring
  bool reads_ring() const;              // a ring is attached now

 private:
  void take(const CORBA::Any& value, const rtm::SenderSeq* order);  // put(), with the order check
  void queue_locked(CORBA::Any value);                               // caller holds mutex_
  void take_from_rings_locked();                                     // caller holds mutex_

  struct Ring {
    std::string name;
    rtm::ShmSegment segment;
    rtm::ShmRingReader reader;
    int attached = 1;  // attach_ring calls not yet undone by detach_ring
  };
  static constexpr std::size_t kMaxRings = 4;

  const std::string owner_;
  CORBA::TypeCode_var type_;
  const std::size_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable arrived_;
  std::deque<CORBA::Any> queue_;
  std::uint64_t received_ = 0, overflowed_ = 0, rejected_ = 0, late_ = 0, shared_memory_ = 0;
  const rtm::RingDataType* ring_type_;  // the type's plain layout, nullptr: CORBA only
  std::vector<std::unique_ptr<Ring>> rings_;
  std::vector<std::byte> datum_;  // one datum taken from a ring
  rtm::SenderOrder order_;
  std::string last_error_;
};

// A WatchPort subscribed (repeated) to an OutPort while this lives: what `rtm watch` and
// rtm serve's plots take a port's data with.
class WatchSubscription {
 public:
  // Makes a WatchPort of owner taking capacity data, activates it in orb and subscribes it to
  // out (the OutPort at address, carrying type). Throws BrowseError "<address> refused <what>"
  // when the publisher refuses, or the CORBA exception of the call (the port deactivated then).
  WatchSubscription(rtm::Orb& orb, CORBA::Object_ptr out, CORBA::TypeCode_ptr type, const std::string& address,
                    std::string owner, std::size_t capacity, const std::string& what);
  ~WatchSubscription();  // finish(), its failure ignored (the publisher may be gone)
  WatchSubscription(const WatchSubscription&) = delete;
  WatchSubscription& operator=(const WatchSubscription&) = delete;

  WatchPort& port() const { return *servant_; }
  // What the publisher dropped for this subscriber; nothing when it does not tell or cannot be asked.
  std::optional<unsigned long long> publisher_dropped() const;
  // Unsubscribes and deactivates, once: the CORBA exception's name when the unsubscribe failed,
  // else "".
  std::string finish();

 private:
  rtm::Orb& orb_;
  RTM::OutPort_var out_;
  RTM::OutPortEx_var out_ex_;
  WatchPort* servant_;
  PortableServer::ServantBase_var keep_;
  RTM::InPort_var in_;
  bool finished_ = false;
};

}  // namespace rtm::cli
