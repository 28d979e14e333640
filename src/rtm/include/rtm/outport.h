// SPDX-License-Identifier: Apache-2.0
// OutPort: the servant that publishes a component's data: pull (get) and push (subscribe).
#pragma once

#include "RTMExt.hh"
#include "rtm/conn_policy.h"
#include "rtm/data.h"
#include "rt/histogram.h"
#include "rtm/inport.h"

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace rtm {

class Orb;

// Data a port's shared-memory ring keeps at least (16 KiB for RTM::TimedFloat6).
inline constexpr std::uint32_t kMinRingSlots = 256;

// Delivery settings of one OutPort.
struct OutPortOptions {
  // The defaults a ConnPolicy (rtm/conn_policy.h) leaves to the port: queue_depth, delivery,
  // call_timeout_ms. The rest bound the port as a whole.
  // Consecutive COMM_FAILURE / TRANSIENT / OBJECT_NOT_EXIST before a subscriber is dropped.
  std::uint32_t max_failures = 3;
  // Bound on one remote put (omniORB client call timeout), ms.
  std::uint32_t call_timeout_ms = 1000;
  // Deliver T straight into InPorts of this process (no any, no ORB). Off: always put(any).
  bool in_process = true;
  // To InPorts of other processes on this host that read a ring (RTM::InPortShm): data go
  // through the port's shared-memory ring (rt/shm_ring.h) and no call is made per datum; the
  // subscriber takes them when its component reads. Repeated subscriptions of plain-memory
  // data only; a subscriber that declines (another host or user, a segment it cannot map) keeps
  // CORBA. Off: CORBA for every subscriber of another process. The ring keeps
  // max(2 x queue_depth, kMinRingSlots) data: a FIFO reader that looks at it every 20 ms (a
  // recorder) loses nothing at 500 Hz even a few hundred ms late.
  bool shared_memory = true;
  // To RTM::InPortEx subscribers use the oneway push() instead of put(): more throughput,
  // but a dead subscriber is only detected by COMM_FAILURE / TRANSIENT.
  bool oneway = false;
  // Data a delivery thread may fall behind by before the oldest are dropped (counted): rides
  // out a subscriber's or the host's short stall without loss, and lets one wake-up deliver
  // a batch. 1 = latest value only. Pre-allocated per subscription.
  std::uint32_t queue_depth = 8;
  // Subscriptions one OutPort takes; more are refused (each remote one has a delivery thread:
  // a flood of subscribe() calls must not make threads without bound).
  std::uint32_t max_subscriptions = 32;
  // Who makes the remote call for a datum.
  //   writer_when_idle: write() itself, when the subscription has nothing in flight or queued
  //     (no thread wake-up between the writer and the wire: the datum leaves at once); else,
  //     and after a call of the writer's failed, the subscription's delivery thread, until
  //     that thread has delivered again.
  //   thread: always the delivery thread; write() never makes a CORBA call.
  // A once-subscription is always served by its thread, under call_timeout_ms: it takes the
  // first datum written after it was made and, should that delivery fail, the next, until one
  // is delivered (a call that timed out may still have arrived: then the subscriber has two).
  enum class Delivery { writer_when_idle, thread };
  Delivery delivery = Delivery::writer_when_idle;
  // Bound on one call made by write() (omniORB client call timeout on a reference of its
  // own), ms; a call that takes longer fails (counted) and moves that subscription to its
  // thread. write() begins no call once writer_call_timeout_ms have passed since it was
  // entered (the rest go to their threads), and makes at most writer_calls (≤ 8): it holds its
  // caller for less than 2 x writer_call_timeout_ms beyond copying into the rings.
  // 0: no bound: write() waits for a stalled subscriber as long as it stalls (as OpenRTM's
  // flush policy does) and saves what omniORB's bound costs each call (a poll() before the
  // send and a timer armed while waiting: docs/performance.md measures it). Opt-in only.
  std::uint32_t writer_call_timeout_ms = 2;
  std::uint32_t writer_calls = 4;
};

// Counters of one OutPort (same meaning as RTM::PortCounters).
struct OutPortCounters {
  std::uint64_t written = 0;   // write() calls
  std::uint64_t refused = 0;   // subscribes refused
  std::uint64_t dropped = 0;   // stale data slow subscribers skipped
  std::uint64_t pushed = 0;    // deliveries completed (in-process ones included)
  std::uint64_t failed = 0;    // deliveries that raised
  std::uint64_t timed_out = 0; // of failed: calls that outlived their bound (TIMEOUT). Such a
                               // datum's fate is unknown (COMPLETED_MAYBE): it may still
                               // arrive, after data sent later on another connection.
  std::uint64_t by_writer = 0; // deliveries write() made itself (Delivery::writer_when_idle)
};

// How long write() held its caller (OutPortBase::write_cost()). Every write() that has a
// remote call to make or a datum to hand to a thread is measured; while the port has only
// shared-memory and direct in-process subscribers (a write that copies and returns, ~0.1 us),
// one write in kWriteCostSampling is, as two clock reads would cost it half as much again.
inline constexpr std::uint64_t kWriteCostSampling = 16;
struct WriteCost {
  std::uint64_t count = 0;  // write() calls measured
  std::int64_t p50_ns = 0, p99_ns = 0;  // upper edges of the 1 us buckets holding them
  std::int64_t max_ns = 0;
};

// ============================ OutPortBase =============================

// The type-independent part: subscriptions, delivery threads, counters, IDL attributes.
//
// Each subscription has a pre-allocated ring of options().queue_depth data not yet delivered.
// To an idle remote subscription (Delivery::writer_when_idle) write() makes the call itself,
// with no lock held; otherwise it copies into the ring and wakes the subscription's delivery
// thread, which takes the data oldest first and calls put() with no lock held. A subscriber
// that falls further behind than the ring loses the oldest data, counted as dropped: it only
// ever misses stale data. In-process subscribers whose policy stores without waiting are
// filled directly by write() (a copy under the InPort's lock, no thread hand-off).
class OutPortBase : public virtual POA_RTM::OutPortEx {
 public:
  ~OutPortBase() override;

  // ---- C++ side ----
  const std::string& port_name() const { return name_; }
  const std::string& owner_name() const { return owner_; }
  std::string full_name() const;  // "<owner>.<name>"
  virtual CORBA::TypeCode_ptr type_code() const = 0;
  // Values in one datum (DataTraits<T>::elements; 0 for a sequence).
  virtual std::size_t element_count() const = 0;
  // What the port carries: as InPortBase::set_info().
  void set_info(PortInfo info);
  const PortInfo& info() const { return info_; }
  const OutPortOptions& options() const { return options_; }  // as constructed
  // Who makes the remote calls of subscriptions made from now on (those made before keep
  // theirs): e.g. set from a runner's command line after the component built its ports.
  void set_delivery(OutPortOptions::Delivery delivery) { delivery_.store(delivery, std::memory_order_relaxed); }
  OutPortOptions::Delivery delivery() const { return delivery_.load(std::memory_order_relaxed); }
  // Whether subscriptions made from now on may take the shared-memory ring
  // (OutPortOptions::shared_memory); those made before keep their path.
  void set_shared_memory(bool on) { shared_memory_.store(on, std::memory_order_relaxed); }
  bool shared_memory() const { return shared_memory_.load(std::memory_order_relaxed); }
  // Cheap (a few relaxed loads): may be polled.
  OutPortCounters counters_snapshot() const;
  // Percentiles of the time write() held its caller (walks a histogram: not for a hot loop).
  WriteCost write_cost() const;
  const LatencyHistogram& write_cost_histogram() const { return write_cost_; }
  std::string last_refusal() const;  // why the last subscribe was refused, "" when none
  std::size_t subscription_count() const;

  RTM::OutPortEx_ptr activate(Orb& orb);  // idempotent
  void deactivate();                      // idempotent; waits until the POA released it
  RTM::OutPortEx_ptr reference() const;   // nil before activate(); caller owns the duplicate
  // Drops every subscription and joins every delivery thread. Idempotent.
  void close();

  // ---- IDL ----
  // subscribe() and connect() are typed: see OutPort<T>.
  // False when i_port has no subscription of type r_type.
  CORBA::Boolean unsubscribe(RTM::ReqType r_type, RTM::InPort_ptr i_port) override;
  char* name() override;
  CORBA::TypeCode_ptr port_type() override;
  char* owner() override;
  RTM::PortCounters counters() override;
  RTM::SubscriptionInfoList* subscriptions() override;
  char* last_error() override;
  RTM::PortDescription* describe() override;

 protected:
  OutPortBase(std::string name, std::string owner, OutPortOptions options);

  // One subscription; the typed slot lives in the derived class.
  struct Subscription {
    virtual ~Subscription() = default;
    bool once() const { return policy.once; }
    ConnPolicy asked;   // as subscribe/connect was given it
    ConnPolicy policy;  // what it is: asked, with the port's defaults filled in
    ConnKind kind = ConnKind::remote_by_thread;
    std::string reader;              // what the InPort keeps, as it tells ("" untold)
    RTM::InPort_var port;            // nil for a C++ connect()
    RTM::InPortEx_var port_ex;       // narrowed when the subscriber is an InPortEx
    RTM::InPortOrdered_var port_ordered;  // ... and when it keeps each sender's order
    std::uint64_t sender = 0;        // this subscription's number for InPortOrdered (random)
    PortableServer::Servant_var<InPortBase> local;  // set for in-process delivery
    // ConnKind::shared_memory: the subscriber reads the port's ring (no call per datum); the
    // subscription's thread only asks, every second, whether the subscriber still exists.
    RTM::InPortShm_var port_shm;
    std::string segment;             // the ring's segment name, told again at detach
    std::string peer;
    bool direct = false;             // in_process, filled by write() itself (no thread)
    bool check_active = true;        // subscribe(): a deactivated local InPort counts as dead
    // Slot state, guarded by slot_mu.
    std::mutex slot_mu;
    std::condition_variable slot_cv;
    std::uint64_t written_seq = 0;
    std::uint64_t delivered_seq = 0;
    bool stop = false;
    bool done = false;               // once-subscription delivered, or dropped as dead
    bool in_flight = false;          // a call for this subscription is being made (writer or thread)
    bool writer_calling = false;     // ... by write(), with no lock held
    bool writer_may_call = true;     // false after a writer's call failed, until the thread delivered
    // Remote and Delivery::writer_when_idle: write()'s own reference (its own call timeout).
    RTM::InPort_var writer_port;
    RTM::InPortEx_var writer_port_ex;
    RTM::InPortOrdered_var writer_port_ordered;
    std::thread thread;
    std::atomic<std::uint64_t> pushed{0};
    std::atomic<std::uint64_t> dropped{0};
    std::atomic<std::uint32_t> failures{0};  // consecutive
    // The last failure's exception (a static name: nothing is allocated on the path), and its
    // minor code when access control refused the datum; cleared by the next delivery.
    std::atomic<const char*> failure_name{nullptr};
    std::atomic<std::uint32_t> refused_minor{0};
    bool failure_logged = false;
  };

  // Adds a subscription made by the derived class; refuses duplicates. Returns false + reason.
  bool add_subscription(std::unique_ptr<Subscription> sub, bool start_thread, std::string& why);
  // Delivery thread body: waits for data, delivers it with no lock held.
  void delivery_loop(Subscription* sub);
  // The thread of a shared-memory subscription: drops it once the subscriber is found dead
  // (max_failures probes in a row, one a second), as failed deliveries would.
  void probe_loop(Subscription* sub);

  // Type-specific delivery of the slot's datum: copies it out under slot_lock, delivers with
  // the lock released, and returns with it held again. Throws what the delivery raised.
  virtual void deliver_slot(Subscription& sub, std::uint64_t seq,
                            std::unique_lock<std::mutex>& slot_lock) = 0;
  // How many data the subscription's ring holds (options().queue_depth, at least 1).
  virtual std::uint64_t ring_size(const Subscription& sub) const = 0;
  // Counts a failed delivery; true when sub must be dropped as dead. Logs the drop once.
  // exception_name: static storage (a CORBA exception's _name()); refused_minor: the minor
  // code of a NO_PERMISSION, else 0.
  bool count_failure(Subscription& sub, const char* exception_name, bool dead_kind, std::uint32_t refused_minor = 0);
  // Counts a datum delivered to sub.
  void count_pushed(Subscription& sub);
  // Runs call() (a delivery) and counts what came of it: true when it returned; *dead when
  // sub must be dropped.
  template <class Call>
  bool guarded_call(Subscription& sub, Call call, bool* dead);
  // write()'s part after its lock: the calls it took on (sub->in_flight set by write()).
  void finish_writer_call(Subscription& sub, bool delivered, bool dead);
  // subscribe(): false (refused, with the reason) when the InPort's access control would
  // refuse every datum of this port; a subscriber that does not answer now passes (the first
  // write() finds it out, as for any subscriber).
  bool admitted(Subscription& sub);
  // Tells a shared-memory subscriber to stop reading the ring; failures are only logged.
  static void detach_quietly(RTM::InPortShm_ptr reader, const std::string& ring);
  // subscribe(): write()'s own references to a remote subscriber, with their call timeout.
  void make_writer_references(Subscription& sub) const;
  // The asked policy with the port's defaults filled in.
  ConnPolicy resolve(const ConnPolicy& asked) const;
  // subscribe()/connect(): false (refused, with the reason) for a depth above kMaxDepth.
  bool depth_allowed(const ConnPolicy& asked);
  // subscribe(): false (refused, with the reason) when the InPort keeps another reader policy
  // than sub.policy asks; sets sub.reader. A remote InPort is asked (bounded).
  bool reader_matches(Subscription& sub, const InPortBase* local);
  // A subscription's sender number for InPortOrdered: random, so that two publishers (or
  // two runs of one) do not share one.
  static std::uint64_t random_sender();
  // Removes the subscriptions matching (under mu_) and stops/joins them (without it).
  bool remove_matching(const std::function<bool(const Subscription&)>& match);
  static void stop_and_join(std::unique_ptr<Subscription> sub, std::vector<std::unique_ptr<Subscription>>& parked);
  // Removes sub from the list (from its own thread) and parks it for joining later.
  void retire(Subscription* sub);
  // Same, from write() (mu_ held): index into subs_.
  void retire_locked(std::size_t index);
  // After subs_ changed (mu_ held): counts the subscriptions write() may call or queue for.
  void subs_changed_locked();
  void reap_retired();  // joins parked threads; never from a delivery thread
  void refuse(const std::string& why);
  // "<owner>.<name>" of an InPort (asks it; RTM::InPort without owner: its name only).
  // "owner.name" of a subscriber, each call bounded by call_timeout_ms.
  static std::string peer_name(RTM::InPort_ptr port, std::uint32_t call_timeout_ms);
  std::string full_port_text() const;  // why a subscribe to a full port is refused

  const std::string name_;
  const std::string owner_;
  const OutPortOptions options_;
  std::atomic<OutPortOptions::Delivery> delivery_;
  std::atomic<bool> shared_memory_;
  PortInfo info_;
  mutable std::mutex mu_;  // guards subs_, retired_, the latest value (derived)
  std::vector<std::unique_ptr<Subscription>> subs_;
  std::vector<std::unique_ptr<Subscription>> retired_;
  std::string last_refusal_;
  std::atomic<std::uint64_t> written_{0};
  std::atomic<std::uint64_t> refused_{0};
  std::atomic<std::uint64_t> dropped_{0};
  std::atomic<std::uint64_t> pushed_{0};
  // Of pushed: into the ring for shared-memory subscribers. Only write() changes it, under
  // mu_, as it does written_: a plain store, not a locked add, per datum.
  std::atomic<std::uint64_t> ring_pushed_{0};
  std::atomic<std::uint64_t> failed_{0};
  std::atomic<std::uint64_t> timed_out_{0};
  std::atomic<std::uint64_t> by_writer_{0};
  // Subscriptions that are neither a ring nor filled directly: while there are none, write()
  // times itself one call in kWriteCostSampling (WriteCost).
  std::atomic<std::uint32_t> calling_subscriptions_{0};
  LatencyHistogram write_cost_;
  bool closed_ = false;
  std::atomic<bool> get_before_data_logged_{false};

 private:
  mutable std::mutex ref_mu_;  // guards orb_, ref_ (not mu_: deactivate waits for upcalls)
  Orb* orb_ = nullptr;
  RTM::OutPortEx_var ref_;
};

// ============================ OutPort<T> ==============================

template <PortData T>
class OutPort final : public OutPortBase {
 public:
  OutPort(std::string name, std::string owner, OutPortOptions options = {});
  ~OutPort() override;

  // Publishes value: keeps it for get(), fills every subscription. With Delivery::thread it
  // makes no CORBA call and, for a fixed-size T, allocates nothing (except when a
  // once-subscription is retired); with writer_when_idle it also makes the calls it takes on
  // (each marshals an any), bounded as OutPortOptions says.
  void write(const T& value);
  // The last written value; false before the first write().
  bool latest(T& out) const;

  // Direct C++ connection to an InPort of this process, without the ORB (composites). The
  // same rules as subscribe(): false (with last_refusal()) for a duplicate or a reader policy
  // the InPort does not keep.
  bool connect(InPort<T>& in, const ConnPolicy& policy = ConnPolicy::repeated());
  bool disconnect(InPort<T>& in);

  CORBA::TypeCode_ptr type_code() const override { return DataTraits<T>::type_code(); }
  std::size_t element_count() const override { return DataTraits<T>::elements; }

  // IDL: the last written value; before the first write raises
  // BAD_INV_ORDER(kMinorNoDataYet, COMPLETED_NO) and logs why.
  CORBA::Any* get() override;
  // Refuses (false, logged, last_error) a nil port, one already subscribed, or one whose
  // port_type is not equivalent to ours. An InPort of this process carrying T is fed without
  // the ORB (SubscriptionInfo.in_process) unless options().in_process is false.
  CORBA::Boolean subscribe(RTM::ReqType r_type, RTM::InPort_ptr i_port) override;
  // subscribe() with a whole policy (RTMExt.idl): a policy out of range, a reader policy the
  // InPort does not keep, or depth > ConnPolicy::kMaxDepth is refused with the reason.
  CORBA::Boolean connect(const RTM::ConnPolicy& policy, RTM::InPort_ptr i_port) override;
  // The same from C++.
  bool subscribe_with(const ConnPolicy& policy, RTM::InPort_ptr i_port);

 private:
  struct TypedSubscription : Subscription {
    // Datum number s (1-based) is ring[(s - 1) % ring.size()] (guarded by slot_mu).
    std::vector<T> ring;
    T sending{};  // the datum being delivered (delivery thread only)
  };
  static constexpr std::size_t kMaxWriterCalls = 8;  // OutPortOptions::writer_calls is capped here
  void deliver_slot(Subscription& sub, std::uint64_t seq, std::unique_lock<std::mutex>& slot_lock) override;
  bool deliver_direct(TypedSubscription& sub, const T& value);
  std::uint64_t queue_or_take(TypedSubscription& sub, const T& value, bool may_call);
  void call_remote(TypedSubscription& sub, const T& value, bool by_writer, std::uint64_t seq);
  void hand_to_thread(TypedSubscription& sub, const T& value);
  std::uint64_t ring_size(const Subscription& sub) const override {
    return static_cast<const TypedSubscription&>(sub).ring.size();
  }
  std::unique_ptr<TypedSubscription> new_subscription(const ConnPolicy& asked) const;
  // subscribe(): offers the port's ring (made at the first offer) to a subscriber of this
  // host; true when it reads from it (sub.kind set to ConnKind::shared_memory).
  bool offer_ring(TypedSubscription& sub);
  // The ring, made at the first offer; written by write() under mu_.
  std::mutex ring_mu_;  // serialises making it
  std::optional<ShmSegment> ring_segment_;
  std::optional<ShmRingWriter> ring_writer_;  // guarded by mu_
  std::uint32_t ring_slots_ = 0;              // guarded by ring_mu_
  T latest_{};
  bool has_latest_ = false;
};

}  // namespace rtm

#include "rtm/outport_impl.h"
