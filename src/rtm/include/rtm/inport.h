// SPDX-License-Identifier: Apache-2.0
// InPort: the servant that receives data (put(any) from the ORB, deliver(T) in-process) and
// keeps it according to a ready policy, the "implementations" the paper asks for.
#pragma once

#include "RTMExt.hh"
#include "rt/activity.h"
#include "rt/shm_ring.h"
#include "rt/shm_segment.h"
#include "rtm/conn_policy.h"
#include "rtm/data.h"
#include "rtm/describe.h"
#include "rtm/read_result.h"
#include "rtm/sender_order.h"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <thread>
#include <type_traits>
#include <typeinfo>
#include <vector>

namespace rtm {

class Orb;
class PortTap;
class TapSink;
template <PortData T>
class TypedTap;

// ============================ policies ================================

// What a full FIFO does with one more datum.
enum class FullPolicy {
  DropOldest,  // make room by discarding the oldest datum (counted as dropped)
  DropNewest,  // discard the arriving datum (counted as dropped)
  Block,       // the putter waits for room up to block_timeout_ns, then drops the new datum
};

// How an InPort keeps what arrives. Named factories, one per pattern:
//   InPortPolicy::latest()                        keep only the newest value
//   InPortPolicy::fifo(8, FullPolicy::DropOldest) bounded queue, pre-allocated
//   InPortPolicy::callback<T>(fn)                 call fn(datum) on arrival (and keep latest)
class InPortPolicy {
 public:
  enum class Kind { Latest, Fifo, Callback };

  static InPortPolicy latest() { return InPortPolicy(Kind::Latest); }
  // capacity >= 1, else std::invalid_argument.
  static InPortPolicy fifo(std::size_t capacity, FullPolicy full = FullPolicy::DropOldest,
                           std::int64_t block_timeout_ns = 1'000'000);
  // fn runs on the thread that delivers: an ORB thread for remote puts, the publisher's
  // delivery thread in-process. It must not throw (an exception is counted and logged once).
  template <PortData T>
  static InPortPolicy callback(std::function<void(const T&)> fn) {
    InPortPolicy p(Kind::Callback);
    p.callback_ = std::make_shared<std::function<void(const T&)>>(std::move(fn));
    p.callback_type_ = &typeid(T);
    return p;
  }

  Kind kind() const { return kind_; }
  std::size_t capacity() const { return capacity_; }
  FullPolicy full_policy() const { return full_; }
  std::int64_t block_timeout_ns() const { return block_timeout_ns_; }

  // The typed callback, or nullptr when the policy is not a callback for T.
  template <PortData T>
  std::shared_ptr<std::function<void(const T&)>> callback_for() const {
    if (kind_ != Kind::Callback || *callback_type_ != typeid(T)) return nullptr;
    return std::static_pointer_cast<std::function<void(const T&)>>(callback_);
  }
  const std::type_info* callback_type() const { return callback_type_; }

 private:
  explicit InPortPolicy(Kind k) : kind_(k) {}
  Kind kind_;
  std::size_t capacity_ = 1;
  FullPolicy full_ = FullPolicy::DropOldest;
  std::int64_t block_timeout_ns_ = 0;
  std::shared_ptr<void> callback_;
  const std::type_info* callback_type_ = nullptr;
};

// Counters of one InPort (same meaning as RTM::PortCounters).
struct InPortCounters {
  std::uint64_t accepted = 0;  // data stored
  std::uint64_t rejected = 0;  // puts refused: wrong type
  std::uint64_t dropped = 0;   // data overwritten unread (latest) or lost to a full FIFO, or late
  std::uint64_t late = 0;      // of dropped: put_in_order data older than one already taken
  std::uint64_t in_process = 0;  // of accepted: delivered without an any (in-process path)
  std::uint64_t shared_memory = 0;  // of accepted: taken from a publisher's shared-memory ring
  std::uint64_t callback_failures = 0;  // callback policy: calls that threw
};

// ============================ port descriptions =======================

// Checks info for a port whose datum holds element_count values (0: a sequence, any number):
// std::invalid_argument naming the port when elements are given and their number differs.
void check_port_info(const std::string& port, std::size_t element_count, const PortInfo& info);
// As RTMExt.idl's PortDescription.
RTM::PortDescription* to_idl(const PortInfo& info);

// What a shared-memory ring of T carries (rt/shm_ring.h's type id): the type's name and size,
// so that a ring of another type or another build's layout of it is refused.
template <PortData T>
std::uint64_t ring_type_id() {
  std::uint64_t hash = 0xcbf29ce484222325ULL;  // FNV-1a
  for (const char c : DataTraits<T>::name) hash = (hash ^ static_cast<unsigned char>(c)) * 0x100000001b3ULL;
  return (hash ^ sizeof(T)) * 0x100000001b3ULL;
}

// ============================ InPortBase ==============================

// The type-independent part of every InPort: IDL attributes, counters, activation, the
// process registry that lets an OutPort of this process find it (in-process fast path).
class InPortBase : public virtual POA_RTM::InPortShm {
 public:
  ~InPortBase() override;

  // ---- C++ side ----
  const std::string& port_name() const { return name_; }
  const std::string& owner_name() const { return owner_; }
  std::string full_name() const;  // "<owner>.<name>"
  const InPortPolicy& policy() const { return policy_; }
  virtual CORBA::TypeCode_ptr type_code() const = 0;
  virtual const std::type_info& data_type() const = 0;
  // Values in one datum (data_elements<T>(); 0 for a sequence).
  virtual std::size_t element_count() const = 0;
  // What the port carries. Set before activate() (the component's constructor); throws
  // std::invalid_argument when elements are given and their number is not element_count().
  void set_info(PortInfo info);
  const PortInfo& info() const { return info_; }
  // Takes what publishers' rings hold first (a lock, no system call).
  InPortCounters counters_snapshot() const;
  // Why the last put was rejected, "" when none: what the IDL's last_error() says, as a
  // std::string (the OutPort's is the same).
  std::string last_error_text() const;

  // Bumped after every stored datum (drives an OnArrivalActivity). May be null.
  void set_arrival_signal(std::shared_ptr<ArrivalSignal> signal);

  // What wait_new_until() found: a datum read() has not given yet was there at once, came
  // while it waited, or did not come before the deadline.
  enum class Awaited { there, arrived, none };
  // Waits, with no lock held, until there is a datum read() has not given yet, or until deadline_ns
  // (CLOCK_MONOTONIC) passed. A periodic reader on a phase just after its writer's calls it at the start of
  // its cycle with a bound inside the period (the runner's --await): a writer a little late then costs the
  // chain that lateness, not a period. From the ring of a sole same-host publisher it is one futex wait,
  // woken by that publisher's next write (which pays one futex wake only while someone waits); from a put or
  // an in-process delivery, a condition variable. No allocation.
  Awaited wait_new_until(std::int64_t deadline_ns);
  std::size_t awaiting() const;  // threads in wait_new_until() now

  // Of a Stamped datum (rtm/data.h): the stamp (CLOCK_REALTIME ns) of the newest datum read()
  // or read_many() gave, and how many new data they gave so far; 0 for other types. The
  // reading cycle's own figures: read on the thread that reads.
  std::int64_t last_stamp_ns() const { return last_stamp_ns_; }
  std::uint64_t stamps_taken() const { return stamps_taken_; }
  virtual bool stamped() const = 0;  // its datum is Stamped
  // The component no longer acts on the newest datum read() gave: it went stale and the
  // component braked (the actuator's watchdog). A chain watched through this port then counts
  // no age and no stale cycle until read() gives a new datum: a servo braked on purpose is not a
  // late chain. On the thread that reads.
  void expire_last() { last_expired_ = true; }
  bool last_expired() const { return last_expired_; }

  // Re-simulation (rtm/cycle_tap.h): a tap logging into `sink` as port `key`, or (sink null)
  // answering reads from a replay. The port keeps a pointer to it until untap(); only while
  // the component does not cycle.
  virtual std::unique_ptr<PortTap> tap(TapSink* sink, std::uint16_t key, std::uint32_t capacity) = 0;
  virtual void untap() = 0;

  // True when storing a datum never waits nor runs user code (latest, FIFO drop-*): an
  // in-process publisher may then store straight from its writing thread.
  bool stores_without_waiting() const;

  // Activates the servant in orb's POA and registers it as local. Idempotent.
  RTM::InPortEx_ptr activate(Orb& orb);
  // Unregisters and deactivates (waits until the POA released it). Idempotent.
  void deactivate();
  bool active() const { return active_.load(std::memory_order_acquire); }
  // The reference (nil before activate()). Caller owns the returned duplicate.
  RTM::InPortEx_ptr reference() const;

  // ---- IDL ----
  char* name() override;
  CORBA::TypeCode_ptr port_type() override;
  char* owner() override;
  RTM::PortCounters counters() override;
  char* last_error() override;
  void push(const CORBA::Any& value) override;  // put() that swallows the BAD_PARAM
  void push_in_order(const CORBA::Any& value, CORBA::ULongLong sender, CORBA::ULongLong seq) override;
  RTM::PortDescription* describe() override;
  void admit_writer() override {}  // the access screen (host/access.h) is the whole answer
  char* reader_policy() override;  // to_string(reader())
  ReaderPolicy reader() const;     // what policy() keeps, as a connection policy names it
  // The same-host path (RTMExt.idl's InPortShm): maps a publisher's ring and takes data from it in read(),
  // from then on; false with why when the port keeps CORBA: another host or network namespace, another type,
  // a datum that is not plain memory, a segment this user cannot map. A port that acts on arrival (callback,
  // an arrival signal, a FIFO that blocks) gets a thread per ring that waits on the ring's futex and stores
  // each datum as a put would, at the path's priority: one wake-up per datum, no call. Rings of publishers
  // that are gone (killed, or restarted as another process) are let go here.
  CORBA::Boolean attach_ring(const char* segment, const char* host, CORBA::ULongLong type_id, CORBA::Long writer_pid,
                             CORBA::ULongLong writer_start, CORBA::String_out why) override;
  // Takes what the ring still holds for this port, then unmaps it.
  CORBA::Boolean detach_ring(const char* segment) override;
  std::size_t attached_rings() const;
  std::size_t ring_waiters() const;  // rings read on arrival by a thread of their own

  // The local InPort servant behind ref (with a reference count added), or nullptr when ref
  // is nil or points into another process.
  static PortableServer::Servant_var<InPortBase> find_local(CORBA::Object_ptr ref);

 protected:
  InPortBase(std::string name, std::string owner, InPortPolicy policy);
  // Counts, logs once per distinct reason and remembers a refused put; then the caller throws.
  void reject(CORBA::TypeCode_ptr got);
  void notify_arrival();  // caller holds mu_: the arrival signal, and wait_new_until()'s waiters
  // Whether read() has something new to give (caller holds mu_; may take from the rings).
  virtual bool has_unread_locked() = 0;
  void callback_failed(const char* what);  // counts; logs the first one

  // A publisher's ring this port reads (guarded by mu_).
  struct AttachedRing {
    std::string name;
    long writer_pid = 0;
    unsigned long long writer_start = 0;
    ShmSegment segment;
    ShmRingReader reader;
    std::uint64_t last_number = 0;  // the last datum taken (latest policy: what it skipped is dropped)
    int attached = 1;               // attach_ring calls not yet undone by detach_ring
    // On arrival: the thread that waits on the ring and alone reads it (read() leaves it be).
    // Set under mu_ while the ring is listed; stopped and joined after it was taken off.
    bool has_waiter = false;
    std::atomic<bool> stop{false};
    std::thread waiter{};
  };
  static constexpr std::size_t kMaxRings = 16;
  // Why a ring cannot be read by this port's type, "" when it can.
  virtual std::string ring_refusal(CORBA::ULongLong type_id) const = 0;
  // Takes the data ring holds for this port into its storage (caller holds mu_).
  virtual void take_from_ring_locked(AttachedRing& ring) = 0;
  // The same for every attached ring a thread does not wait on (caller holds mu_). The port's
  // storage changes, not what a caller sees of it: const for counters_snapshot() and queued().
  void take_from_rings_locked() const {
    for (const auto& ring : rings_)
      if (!ring->has_waiter) const_cast<InPortBase*>(this)->take_from_ring_locked(*ring);
  }
  // On arrival: stores each datum ring holds that this port did not take yet, as a put would (callback,
  // arrival signal, a FIFO that waits for room), oldest first. No lock held; only the ring's waiter (or, once
  // it is joined, whoever took the ring off) calls it. Returns how many data it took from the ring.
  virtual std::size_t store_from_ring(AttachedRing& ring) = 0;
  // Whether data must be stored as they arrive rather than when read (caller holds mu_).
  bool acts_on_arrival_locked() const { return !stores_without_waiting() || signal_ != nullptr; }
  void start_waiter_locked(AttachedRing& ring);  // caller holds mu_
  void waiter_loop(AttachedRing* ring);
  // Stops and joins ring's waiter (no lock held); keep_rest: then stores what the ring still
  // holds (an unsubscribe keeps what came before it).
  void stop_waiter(AttachedRing& ring, bool keep_rest);
  // Takes every ring with a waiter off and stops it (~InPort, deactivate): no callback runs after either.
  void stop_ring_waiters();
  // guarded by mu_; shared: wait_new_until() keeps the ring it waits on without the lock
  std::vector<std::shared_ptr<AttachedRing>> rings_;
  std::atomic<std::uint64_t> shared_memory_{0};
  // The reading thread's (last_stamp_ns()).
  std::int64_t last_stamp_ns_ = 0;
  std::uint64_t stamps_taken_ = 0;
  bool last_expired_ = false;

  const std::string name_;
  const std::string owner_;
  const InPortPolicy policy_;
  PortInfo info_;
  mutable std::mutex mu_;  // guards the stored data, the signal and last_error_
  std::shared_ptr<ArrivalSignal> signal_;
  // wait_new_until(): threads in it, the condition variable they wait on, and the ring one
  // of them waits on (a put wakes it through the ring's word). Guarded by mu_.
  int awaiting_ = 0;
  std::condition_variable arrival_cv_;
  AttachedRing* awaited_ring_ = nullptr;
  std::atomic<bool> await_cancel_{false};  // set by a store while one waits on a ring
  std::string last_error_;
  std::atomic<std::uint64_t> accepted_{0};
  std::atomic<std::uint64_t> rejected_{0};
  std::atomic<std::uint64_t> dropped_{0};
  std::atomic<std::uint64_t> in_process_{0};
  std::atomic<std::uint64_t> callback_failures_{0};
  std::atomic<std::uint64_t> late_{0};
  SenderOrder order_;  // guarded by mu_

 private:
  std::mutex activation_mu_;  // serialises activate()/deactivate()
  Orb* orb_ = nullptr;        // guarded by the registry lock
  RTM::InPortEx_var ref_;     // guarded by the registry lock
  std::atomic<bool> active_{false};
};

// ============================ InPort<T> ===============================

// An InPort of T. Storage is allocated at construction: put/deliver/read of a fixed-size T allocate nothing.
template <PortData T>
class InPort final : public InPortBase {
 public:
  InPort(std::string name, std::string owner, InPortPolicy policy = InPortPolicy::latest());
  ~InPort() override { stop_ring_waiters(); }  // here: the waiters call store_from_ring()

  // Latest/callback: copies the newest value. FIFO: pops the oldest.
  ReadResult read(T& out);
  // The new data, oldest first, as many as out holds, under one lock: FIFO pops up to out.size();
  // latest/callback gives the newest if it is unread (then 1). Returns how many were copied (0: nothing new).
  // A reader that drains a FIFO each cycle pays one lock for all, not one per datum.
  std::size_t read_many(std::span<T> out);
  // Stores value as a put would (the in-process path; counted in counters().in_process).
  void deliver(const T& value);
  std::unique_ptr<PortTap> tap(TapSink* sink, std::uint16_t key, std::uint32_t capacity) override;
  void untap() override { tap_ = nullptr; }
  std::size_t queued() const;  // FIFO length now; latest: 1 if unread data, else 0

  CORBA::TypeCode_ptr type_code() const override { return DataTraits<T>::type_code(); }
  const std::type_info& data_type() const override { return typeid(T); }
  std::size_t element_count() const override { return data_elements<T>(); }
  bool stamped() const override { return Stamped<T>; }

  // IDL: extracts T; any other type raises BAD_PARAM(kMinorWrongDataType, COMPLETED_NO) and
  // stores nothing (see last_error for the reason).
  void put(const CORBA::Any& value) override;
  // The same, unless the datum is late for its sender (then dropped, counted as late).
  void put_in_order(const CORBA::Any& value, CORBA::ULongLong sender, CORBA::ULongLong seq) override;

 private:
  ReadResult read_port(T& out);                // read() without a tap
  std::size_t read_many_port(std::span<T> out);  // read_many() without a tap
  const T& extract(const CORBA::Any& value);  // the datum, or reject() and BAD_PARAM
  // order: checked under the same lock as the store. Caller holds no lock. False when the datum was dropped.
  bool store(const T& value, bool in_process, const SenderSeq* order = nullptr);
  bool has_unread_locked() override;
  // A FIFO that drops its oldest, with nothing queued (caller holds mu_): takes up to out.size() data
  // straight from the rings no thread waits on, oldest first, without copying them into the queue. Of a
  // backlog longer than the queue's capacity only the newest `capacity` are taken, the rest counted as
  // dropped, as keep() would: a reader slower than its writer pays per datum it takes, not per datum written.
  std::size_t take_straight_locked(std::span<T> out);
  bool reads_rings_straight() const {
    return policy_.kind() == InPortPolicy::Kind::Fifo && policy_.full_policy() == FullPolicy::DropOldest;
  }
  std::size_t store_from_ring(AttachedRing& ring) override;
  // The policy's part of a store; false when the datum was dropped. lock holds mu_.
  bool keep(const T& value, std::unique_lock<std::mutex>& lock);
  std::string ring_refusal(CORBA::ULongLong type_id) const override;
  void take_from_ring_locked(AttachedRing& ring) override;
  std::vector<T> ring_;        // latest: 1 slot; FIFO: capacity slots
  std::size_t head_ = 0;       // FIFO: index of the oldest
  std::size_t count_ = 0;      // FIFO: stored; latest: 1 once written
  bool unread_ = false;        // latest: the slot was not read yet
  bool ever_read_ = false;
  T last_read_{};
  std::condition_variable space_cv_;  // FIFO Block: a read made room
  std::shared_ptr<std::function<void(const T&)>> callback_;
  TypedTap<T>* tap_ = nullptr;  // re-simulation; the cycle thread's
};

}  // namespace rtm

#include "rtm/inport_impl.h"

namespace rtm {
// The built-in types' InPorts are instantiated once, in the library (port_types.cpp): a
// component's own files only use them, which keeps the build of a component short.
#define RTM_EXTERN_IN_PORT(Type, Shape, Member, Elements, ElementType) extern template class InPort<RTM::Type>;
RTM_BUILTIN_DATA_TYPES(RTM_EXTERN_IN_PORT)
#undef RTM_EXTERN_IN_PORT
}  // namespace rtm
