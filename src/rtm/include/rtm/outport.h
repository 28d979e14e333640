// SPDX-License-Identifier: Apache-2.0
// OutPort: the servant that publishes a component's data: pull (get) and push (subscribe).
#pragma once

#include "RTMExt.hh"
#include "rtm/conn_policy.h"
#include "rtm/connection.h"
#include "rtm/data.h"
#include "rt/histogram.h"
#include "rtm/inport.h"

#include <array>
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

// Delivery settings of one OutPort: queue_depth, delivery and call_timeout_ms are the defaults a ConnPolicy
// (rtm/conn_policy.h) leaves to the port; the rest bound the port as a whole.
struct OutPortOptions {
  // Consecutive COMM_FAILURE / TRANSIENT / OBJECT_NOT_EXIST before a subscriber is dropped.
  std::uint32_t max_failures = 3;
  // Bound on one remote put (omniORB client call timeout), ms.
  std::uint32_t call_timeout_ms = 1000;
  // Deliver T straight into InPorts of this process (no any, no ORB). Off: always put(any).
  bool in_process = true;
  // To InPorts of other processes on this host that read a ring (RTM::InPortShm): data go through the port's
  // shared-memory ring (rt/shm_ring.h) and no call is made per datum; the subscriber takes them when its
  // component reads. Repeated subscriptions of plain-memory data only; a subscriber that declines (another
  // host or user, a segment it cannot map) keeps CORBA. Off: CORBA for every subscriber of another process.
  // The ring keeps max(2 x queue_depth, kMinRingSlots, the first subscriber's depth) data: a FIFO reader that
  // looks at it every 20 ms (a recorder) loses nothing at 500 Hz even a few hundred ms late.
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
  //   writer_when_idle: write() itself, when the subscription has nothing in flight or queued (no thread
  //     wake-up between the writer and the wire: the datum leaves at once); else, and after a call of the
  //     writer's failed, the subscription's delivery thread, until that thread has delivered again.
  //   thread: always the delivery thread; write() never makes a CORBA call.
  // A once-subscription is always served by its thread, under call_timeout_ms: it takes the
  // first datum written after it was made and, should that delivery fail, the next, until one
  // is delivered (a call that timed out may still have arrived: then the subscriber has two).
  enum class Delivery { writer_when_idle, thread };
  Delivery delivery = Delivery::writer_when_idle;
  // Bound on one call made by write() (omniORB client call timeout on a reference of its own), ms; a call
  // that takes longer fails (counted) and moves that subscription to its thread. write() begins no call once
  // writer_call_timeout_ms have passed since it was entered (the rest go to their threads), and makes at most
  // writer_calls (≤ 8): it holds its caller for less than 2 x writer_call_timeout_ms beyond copying into the
  // rings. 0: no bound: write() waits for a stalled subscriber as long as it stalls (as OpenRTM's flush
  // policy does) and saves what omniORB's bound costs each call (a poll() before the send and a timer armed
  // while waiting: docs/performance.md measures it). Opt-in only.
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
  std::int64_t p50_ns = 0, p99_ns = 0;  // upper edges of the histogram buckets holding them (rt/histogram.h)
  std::int64_t max_ns = 0;
};

// ============================ OutPortBase =============================

// The type-independent part: the list of connections (rtm/connection.h), counters, IDL
// attributes. A subscribe or connect negotiates with the InPort and makes one connection of
// the kind that fits (ConnKind); write() hands each datum to each.
class OutPortBase : public virtual POA_RTM::OutPortEx {
 public:
  ~OutPortBase() override;

  // ---- C++ side ----
  const std::string& port_name() const { return name_; }
  const std::string& owner_name() const { return owner_; }
  std::string full_name() const;  // "<owner>.<name>"
  virtual CORBA::TypeCode_ptr type_code() const = 0;
  // Values in one datum (data_elements<T>(); 0 for a sequence).
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
  // Why the last subscribe or connect was refused, "" when none: what the IDL's last_error()
  // says, as a std::string (the InPort's is the same).
  std::string last_error_text() const;
  std::size_t subscription_count() const;

  // Its datum is Stamped (rtm/data.h): it carries the stamp of the sample it derives from.
  virtual bool stamped() const = 0;
  // Declares what this port's data derive from: from now on write() gives each datum the stamp
  // of the oldest of the newest data read from inputs (InPortBase::last_stamp_ns()), so the end
  // of a chain sees the age of the sample the chain started from without the component copying
  // tm itself. The oldest: a datum is as old as the oldest input it was computed from (list
  // only the inputs a chain runs through; a reference held on purpose would make every datum
  // look stale). Before any of inputs has given a stamped datum (one stamped 0 counts as none),
  // a datum keeps its own stamp. An
  // empty list ends the derivation. Only while the component does not cycle: the inputs are
  // read on the writing thread, which must be the one that reads them (the cycle). Throws
  // std::invalid_argument for a port or an input that is not Stamped, a null input, or more
  // than kMaxStampSources inputs.
  static constexpr std::size_t kMaxStampSources = 8;
  void derive_stamp_from(const std::vector<const InPortBase*>& inputs);
  // The ports' names, "" when none ("wrench" or "wrench+reference").
  std::string stamp_sources_text() const;

  // Re-simulation: as InPortBase::tap(). A replay's tap keeps what write() wrote instead of
  // publishing it.
  virtual std::unique_ptr<PortTap> tap(TapSink* sink, std::uint16_t key, std::uint32_t capacity) = 0;
  virtual void untap() = 0;

  RTM::OutPortEx_ptr activate(Orb& orb);  // idempotent
  void deactivate();                      // idempotent; waits until the POA released it
  RTM::OutPortEx_ptr reference() const;   // nil before activate(); caller owns the duplicate
  // Drops every subscription and joins every delivery thread. Idempotent.
  void close();

  // OutPort<T>::connect()/disconnect() to an InPort of this process known by its base (a
  // diagram's wiring). False, with last_error_text(), when in carries another type.
  virtual bool connect_local(InPortBase& in, const ConnPolicy& policy) = 0;
  virtual bool disconnect_local(InPortBase& in) = 0;

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

  // Adds a connection made by the derived class and starts its thread: what subscribe/connect
  // return. A duplicate, a full or a closed port is refused with the reason (refuse()), and
  // the connection stopped (a ring's subscriber detaches).
  bool add_connection(std::unique_ptr<Connection> connection);
  // subscribe(): false (refused, with the reason) when the InPort's access control would refuse every datum
  // of this port; one not answering now passes (the first write() finds it out, as for any subscriber).
  bool admitted(const Subscriber& who);
  // The asked policy with the port's defaults filled in.
  ConnPolicy resolve(const ConnPolicy& asked) const;
  // subscribe()/connect(): false (refused, with the reason) for a depth above kMaxDepth.
  bool depth_allowed(const ConnPolicy& asked);
  // subscribe(): false (refused, with the reason) when the InPort keeps another reader policy
  // than who.policy asks; sets who.reader. A remote InPort is asked (bounded).
  bool reader_matches(Subscriber& who);
  // Removes the connections matching (under mu_) and stops/joins them (without it).
  bool remove_matching(const std::function<bool(const Connection&)>& match);
  // Stops and joins c, or parks it when c's own thread is the caller.
  static void stop_and_join(std::unique_ptr<Connection> c, std::vector<std::unique_ptr<Connection>>& parked);
  // Takes c off the list (from its own thread) and parks it for joining later.
  void retire(Connection* c);
  // Same, from write() (mu_ held): index into conns_.
  void retire_locked(std::size_t index);
  // After conns_ changed (mu_ held): counts the connections write() may call or queue for.
  void conns_changed_locked();
  void reap_retired();  // joins parked threads; never from a delivery thread
  void refuse(const std::string& why);
  // refuse(): "<this port> (<its type>) -> <peer> (<their type>): types differ" (their_type borrowed).
  void refuse_types(const std::string& peer, CORBA::TypeCode_ptr their_type);
  // "owner.name" of a subscriber, each call bounded by call_timeout_ms (RTM::InPort without owner: its name).
  static std::string peer_name(RTM::InPort_ptr port, std::uint32_t call_timeout_ms);
  std::string full_port_text() const;  // why a subscribe to a full port is refused
  // derive_stamp_from(): the oldest newest stamp of its inputs; 0 when none gave one yet.
  std::int64_t derived_stamp_ns() const;
  bool derives_stamp() const { return stamp_source_count_ != 0; }

  const std::string name_;
  const std::string owner_;
  const OutPortOptions options_;
  std::atomic<OutPortOptions::Delivery> delivery_;
  std::atomic<bool> shared_memory_;
  PortInfo info_;
  ConnectionHost host_;    // the counters the connections add to
  mutable std::mutex mu_;  // guards conns_, retired_, the latest value (derived)
  std::vector<std::unique_ptr<Connection>> conns_;
  std::vector<std::unique_ptr<Connection>> retired_;
  std::string last_error_;
  std::atomic<std::uint64_t> written_{0};
  std::atomic<std::uint64_t> refused_{0};
  // Connections write() calls or queues for: while there are none, write() times itself one
  // call in kWriteCostSampling (WriteCost).
  std::atomic<std::uint32_t> calling_connections_{0};
  LatencyHistogram write_cost_;
  bool closed_ = false;
  std::atomic<bool> get_before_data_logged_{false};
  std::array<const InPortBase*, kMaxStampSources> stamp_sources_{};  // the writing thread's
  std::size_t stamp_source_count_ = 0;

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

  // Publishes value: keeps it for get(), fills every subscription. With Delivery::thread it makes no CORBA
  // call and, for a fixed-size T, allocates nothing (except when a once-subscription is retired); with
  // writer_when_idle it also makes the calls it takes on (each marshals an any), bounded per OutPortOptions.
  void write(const T& value);
  // The last written value; false before the first write().
  bool latest(T& out) const;
  std::unique_ptr<PortTap> tap(TapSink* sink, std::uint16_t key, std::uint32_t capacity) override;
  void untap() override { tap_ = nullptr; }

  // Direct C++ connection to an InPort of this process, without the ORB (composites). The same rules as
  // subscribe(): false (with last_error_text()) for a duplicate or a reader policy the InPort does not keep.
  bool connect(InPort<T>& in, const ConnPolicy& policy = ConnPolicy::repeated());
  bool disconnect(InPort<T>& in);
  bool connect_local(InPortBase& in, const ConnPolicy& policy) override;
  bool disconnect_local(InPortBase& in) override;

  CORBA::TypeCode_ptr type_code() const override { return DataTraits<T>::type_code(); }
  std::size_t element_count() const override { return data_elements<T>(); }
  bool stamped() const override { return Stamped<T>; }

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
  static constexpr std::size_t kMaxWriterCalls = 8;  // OutPortOptions::writer_calls is capped here
  // subscribe(): what the InPort at i_port is and keeps (false: refused, with the reason).
  bool negotiate(Subscriber& who, RTM::InPort_ptr i_port);
  // The connection for who: in-process, the ring, or CORBA.
  std::unique_ptr<Connection> make_connection(Subscriber who);
  // subscribe(): offers the port's ring (made at the first offer) to a subscriber of this
  // host; true when it reads from it (reader set, and the ring's segment name).
  bool offer_ring(const Subscriber& who, RTM::InPortShm_var& reader, std::string& segment);
  // The ring, made at the first offer; written by write() under mu_.
  std::mutex ring_mu_;  // serialises making it
  std::optional<ShmSegment> ring_segment_;
  std::optional<ShmRingWriter> ring_writer_;  // guarded by mu_
  std::uint32_t ring_slots_ = 0;              // guarded by ring_mu_
  // write() with the datum as given, or as restamped by derive_stamp_from().
  void publish(const T& value);
  T latest_{};
  T restamped_{};  // the writing thread's: a derived datum, copied into storage kept for it
  bool has_latest_ = false;
  TypedTap<T>* tap_ = nullptr;  // re-simulation; the cycle thread's
};

}  // namespace rtm

#include "rtm/outport_impl.h"

namespace rtm {
// The built-in types' OutPorts are instantiated once, in the library (port_types.cpp), as
// their InPorts are (inport.h).
#define RTM_EXTERN_OUT_PORT(Type, Shape, Member, Elements, ElementType) extern template class OutPort<RTM::Type>;
RTM_BUILTIN_DATA_TYPES(RTM_EXTERN_OUT_PORT)
#undef RTM_EXTERN_OUT_PORT
}  // namespace rtm
