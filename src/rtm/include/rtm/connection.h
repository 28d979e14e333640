// SPDX-License-Identifier: Apache-2.0
// Connections: what one subscription of an OutPort is. Its kind (ConnKind) is chosen per
// subscription at subscribe/connect, from its ConnPolicy and from where the InPort is, and each
// kind is a class. The OutPort keeps a list of connections and hands each datum to each
// (TypedConnection<T>::push); what happens to the datum then is the kind's:
//
//   DirectConnection<T>   in_process, to an InPort that stores without waiting: write() stores into it (a
//                         copy under the InPort's lock; no thread, no any)
//   QueuedConnection<T>   in_process, to an InPort whose storing may wait or runs user code: write() queues,
//                         the connection's delivery thread delivers
//   RemoteConnection<T>   remote_by_writer / remote_by_thread: queued, and each delivery is a CORBA call;
//                         while the connection is idle write() may make the call itself (remote_by_writer),
//                         bounded by the port
//   RingConnection<T>     shared_memory: the subscriber reads the port's ring in its own cycle; write() only
//                         counts, and a probe thread finds a subscriber that is gone
//
// A queued connection keeps a pre-allocated ring of policy().depth data not yet delivered and
// its thread takes them oldest first with no lock held; a subscriber that falls further behind
// loses the oldest, counted as dropped: it only ever misses stale data.
#pragma once

#include "RTMExt.hh"
#include "rtm/conn_policy.h"
#include "rtm/data.h"
#include "rtm/inport.h"

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace rtm {

class Connection;

// What an OutPort's connections need of it and add to: set up by the port, one per port.
struct ConnectionHost {
  std::string name;               // "<owner>.<port>", for the logs
  std::uint32_t max_failures = 3;  // OutPortOptions::max_failures
  bool oneway = false;             // OutPortOptions::oneway
  std::uint32_t writer_call_timeout_ms = 2;
  std::atomic<std::uint64_t> pushed{0};  // deliveries completed (in the ring: ring_pushed)
  // Data put into the port's ring for shared-memory subscribers. Only write() changes it,
  // under the port's lock: a plain store, not a locked add, per datum.
  std::atomic<std::uint64_t> ring_pushed{0};
  std::atomic<std::uint64_t> dropped{0};
  std::atomic<std::uint64_t> failed{0};
  std::atomic<std::uint64_t> timed_out{0};
  std::atomic<std::uint64_t> by_writer{0};
  // Takes a connection off the port's list (from its own thread, no lock held); the port joins it later.
  std::function<void(Connection*)> retire;
};

// Whom a subscribe/connect found at the other end, and on what terms: what the OutPort negotiates first.
struct Subscriber {
  ConnPolicy asked;    // as subscribe/connect was given it
  ConnPolicy policy;   // what it is: asked, with the port's defaults filled in
  std::string peer;    // "<owner>.<name>" of the InPort
  std::string reader;  // what the InPort keeps, as it tells ("" untold)
  RTM::InPort_var port;                  // nil for a C++ connect()
  RTM::InPortEx_var port_ex;             // narrowed when the subscriber is an InPortEx
  RTM::InPortOrdered_var port_ordered;   // ... and when it keeps each sender's order
  PortableServer::Servant_var<InPortBase> local;  // an InPort of this process
  bool check_active = true;  // subscribe(): a deactivated local InPort counts as dead
};

// ============================ Connection ==============================

// What every kind has: its subscriber, policy, counters and (for most kinds) a thread.
class Connection {
 public:
  virtual ~Connection() = default;
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  ConnKind kind() const { return kind_; }
  bool once() const { return who_.policy.once; }
  const Subscriber& subscriber() const { return who_; }
  // write() calls or queues for it per datum (else it stores or only counts): while no
  // connection of a port does, that port's write() times one call in kWriteCostSampling.
  virtual bool calls_or_queues() const { return true; }

  // Starts the kind's thread, if it has one: named "rtm-deliver", and at the real-time path's
  // priority (rt/thread.h) when data pass it, set before this returns.
  void start();
  // Stops the connection: its thread, and a call write() is making for it, end first; then the kind's goodbye
  // (a ring's subscriber is told to detach). False when called from the connection's own thread (a callback
  // that unsubscribes): its owner must keep it and detach_thread() later, as a thread cannot join itself.
  bool stop_and_join();
  void detach_thread();

  // The same subscriber as other's (a duplicate subscribe).
  bool same_subscriber(const Connection& other) const;
  // Whether this is the subscription unsubscribe(once, port) names (`local`: port's servant
  // when it is in this process).
  bool is(bool once, RTM::InPort_ptr port, const InPortBase* local) const;
  // What `rtm ls -l` / `rtm cat` show of it.
  void describe(RTM::SubscriptionInfo& info) const;

 protected:
  Connection(ConnectionHost& host, ConnKind kind, Subscriber who);

  virtual bool has_thread() const { return true; }
  virtual bool carries_data() const { return true; }  // a ring's probe carries none
  virtual void run() {}                                // the thread's body
  // stop_and_join(), slot_mu_ held, after stop_ is set: waits until write() no longer makes a
  // call for this connection (with no lock held, it must end before the connection goes).
  virtual void wait_for_writer(std::unique_lock<std::mutex>&) {}
  virtual void stopped() {}  // after the thread ended

  // Counts a failed delivery; true when the connection must go as dead (dead_kind, and
  // max_failures in a row). Logs the drop, and the first failure. exception_name: static
  // storage (a CORBA exception's _name()); refused_minor: a NO_PERMISSION's minor code, else 0.
  bool count_failure(const char* exception_name, bool dead_kind, std::uint32_t refused_minor = 0);
  void count_pushed();
  // Runs call() (a delivery), counts the outcome: true when it returned; *dead when the connection must go.
  template <class Call>
  bool guarded_call(Call call, bool* dead);
  // From the connection's own thread: marks it done and takes it off the port's list.
  void leave();

  ConnectionHost& host_;
  ConnKind kind_;  // set by the constructors only
  const Subscriber who_;
  std::atomic<std::uint64_t> pushed_{0};
  std::atomic<std::uint64_t> dropped_{0};
  std::atomic<std::uint32_t> failures_{0};  // consecutive
  // The last failure's exception (a static name: nothing is allocated on the path), and its
  // minor code when access control refused the datum; cleared by the next delivery.
  std::atomic<const char*> failure_name_{nullptr};
  std::atomic<std::uint32_t> refused_minor_{0};
  bool failure_logged_ = false;
  // The thread's state, guarded by slot_mu_.
  std::mutex slot_mu_;
  std::condition_variable slot_cv_;
  bool stop_ = false;
  bool done_ = false;  // a once-connection delivered, or dropped as dead
  std::thread thread_;
};

// A connection for data of type T: what write() does with one datum.
template <PortData T>
class TypedConnection : public Connection {
 public:
  // What push() leaves write() to do: take the connection off the list (its InPort is gone,
  // or a once-connection delivered), or make a call for datum number call_seq itself, after
  // the port's lock is released (writer_call()).
  struct Push {
    bool retire = false;
    std::uint64_t call_seq = 0;
  };
  // write(), the port's lock held. may_call: write() may still take a call on.
  virtual Push push(const T& value, bool may_call) = 0;
  // The call push() took on; within_budget false: write() has spent its time, the datum goes
  // to the connection's thread instead.
  virtual void writer_call(const T&, std::uint64_t, bool) {}

 protected:
  using Connection::Connection;
};

// ============================ the kinds ===============================

template <PortData T>
class DirectConnection final : public TypedConnection<T> {
 public:
  DirectConnection(ConnectionHost& host, Subscriber who)
      : TypedConnection<T>(host, ConnKind::in_process, std::move(who)) {}
  bool calls_or_queues() const override { return false; }
  typename TypedConnection<T>::Push push(const T& value, bool may_call) override;

 protected:
  bool has_thread() const override { return false; }
};

template <PortData T>
class RingConnection final : public TypedConnection<T> {
 public:
  // `reader` attached to the port's ring, named `segment`.
  RingConnection(ConnectionHost& host, Subscriber who, RTM::InPortShm_var reader, std::string segment)
      : TypedConnection<T>(host, ConnKind::shared_memory, std::move(who)),
        reader_(std::move(reader)),
        segment_(std::move(segment)) {}
  bool calls_or_queues() const override { return false; }
  typename TypedConnection<T>::Push push(const T& value, bool may_call) override;

 protected:
  bool carries_data() const override { return false; }
  void run() override;
  void stopped() override;

 private:
  RTM::InPortShm_var reader_;
  const std::string segment_;
};

// Tells a shared-memory subscriber to stop reading the ring `segment`; failures only logged.
void detach_quietly(RTM::InPortShm_ptr reader, const std::string& segment);

template <PortData T>
class QueuedConnection : public TypedConnection<T> {
 public:
  QueuedConnection(ConnectionHost& host, Subscriber who) : QueuedConnection(host, ConnKind::in_process, std::move(who)) {}
  typename TypedConnection<T>::Push push(const T& value, bool may_call) override;

 protected:
  QueuedConnection(ConnectionHost& host, ConnKind kind, Subscriber who);
  void run() override;  // the delivery loop
  // push(), slot_mu_ held: takes the call on for write() instead of queueing (in_flight_ set)
  // and returns the datum's number, or 0.
  virtual std::uint64_t take_call_locked(bool) { return 0; }
  // One datum to the subscriber, no lock held; throws what the delivery raised.
  virtual void deliver(const T& value, std::uint64_t seq);
  virtual void delivered() {}  // the thread delivered a datum (slot_mu_ held)

  // Datum number s (1-based) is ring_[(s - 1) % ring_.size()]. Guarded by slot_mu_.
  std::vector<T> ring_;
  std::uint64_t written_seq_ = 0;
  std::uint64_t delivered_seq_ = 0;
  bool in_flight_ = false;  // a call for this connection is being made (write() or the thread)

 private:
  T sending_{};  // the datum being delivered (the thread only)
};

// write()'s own references to a remote subscriber, with write()'s call bound: omniORB keeps
// call timeouts per reference, so the delivery thread's longer bound stays on the subscriber's.
// Nil when there is no ORB (then the thread delivers).
struct WriterReferences {
  RTM::InPort_var port;
  RTM::InPortEx_var port_ex;
  RTM::InPortOrdered_var port_ordered;
};
WriterReferences make_writer_references(const Subscriber& who, std::uint32_t writer_call_timeout_ms, bool oneway);
// A connection's sender number for InPortOrdered: random, so that two publishers (or two runs
// of one) do not share one.
std::uint64_t random_sender();

template <PortData T>
class RemoteConnection final : public QueuedConnection<T> {
 public:
  // by_writer: remote_by_writer when write() gets references of its own (never for a
  // once-connection: its thread makes the call, under the connection's bound).
  RemoteConnection(ConnectionHost& host, Subscriber who, bool by_writer);
  void writer_call(const T& value, std::uint64_t seq, bool within_budget) override;

 protected:
  void deliver(const T& value, std::uint64_t seq) override { call(value, false, seq); }
  void delivered() override { writer_may_call_ = true; }  // write() may call again
  void wait_for_writer(std::unique_lock<std::mutex>& slot_lock) override;
  // While idle, and unless its last call failed, write() makes the call itself.
  std::uint64_t take_call_locked(bool may_call) override;

 private:
  // Datum number seq to the subscriber: by_writer selects write()'s references. An
  // InPortOrdered is told the sender number and seq, so that a datum that arrives after a
  // later one (behind a call that timed out) is dropped there, not taken.
  void call(const T& value, bool by_writer, std::uint64_t seq);
  // After write()'s call: counted, the connection retired when dead or a once delivered.
  void finish_writer_call(bool delivered, bool dead);

  WriterReferences writer_;
  std::uint64_t sender_ = 0;
  bool writer_calling_ = false;   // write() makes a call, with no lock held (slot_mu_)
  bool writer_may_call_ = true;   // false after a writer's call failed, until the thread delivered
};

}  // namespace rtm

#include "rtm/connection_impl.h"
