// SPDX-License-Identifier: Apache-2.0
// Template definitions of rtm/outport.h; include that header, not this one.
#pragma once

#include "rt/clock.h"
#include "rtm/access.h"
#include "rtm/log.h"

#include <algorithm>
#include <array>

#include <omniORB4/omniORB.h>

namespace rtm {

template <PortData T>
OutPort<T>::OutPort(std::string name, std::string owner, OutPortOptions options)
    : OutPortBase(std::move(name), std::move(owner), options) {}

template <PortData T>
OutPort<T>::~OutPort() {
  // Here, not in ~OutPortBase: delivery threads call deliver_slot(), which needs this class.
  close();
}

template <class Call>
bool OutPortBase::guarded_call(Subscription& sub, Call call, bool* dead) {
  *dead = false;
  try {
    call();
    count_pushed(sub);
    return true;
  } catch (const CORBA::OBJECT_NOT_EXIST& e) {
    *dead = count_failure(sub, e._name(), true);
  } catch (const CORBA::COMM_FAILURE& e) {
    *dead = count_failure(sub, e._name(), true);
  } catch (const CORBA::TRANSIENT& e) {
    *dead = count_failure(sub, e._name(), true);
  } catch (const CORBA::TIMEOUT& e) {
    timed_out_.fetch_add(1, std::memory_order_relaxed);
    *dead = count_failure(sub, e._name(), false);
  } catch (const CORBA::NO_PERMISSION& e) {
    *dead = count_failure(sub, e._name(), false, e.minor());
  } catch (const CORBA::Exception& e) {
    *dead = count_failure(sub, e._name(), false);
  } catch (const std::exception& e) {
    *dead = count_failure(sub, "a C++ exception", false);
  }
  return false;
}

template <PortData T>
void OutPort<T>::write(const T& value) {
  // Timed always when it may call or queue, else one call in kWriteCostSampling (WriteCost).
  // The counter is read before the lock: a subscription made meanwhile is seen below.
  bool timed = calling_subscriptions_.load(std::memory_order_relaxed) != 0 ||
               written_.load(std::memory_order_relaxed) % kWriteCostSampling == 0;
  std::int64_t start_ns = timed ? monotonic_ns() : 0;
  // Subscriptions write() delivers to itself, after its lock is released (fixed capacity:
  // write() allocates nothing).
  struct Call {
    TypedSubscription* sub;
    std::uint64_t seq;
  };
  std::array<Call, kMaxWriterCalls> calls;
  std::size_t call_count = 0;
  const std::size_t call_limit = std::min<std::size_t>(options_.writer_calls, kMaxWriterCalls);
  {
    std::lock_guard lock(mu_);
    latest_ = value;
    has_latest_ = true;
    // Counters only write() changes, under mu_: stores, not locked adds (a few per datum).
    const auto bump = [](std::atomic<std::uint64_t>& n) {
      n.store(n.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
    };
    bump(written_);
    if constexpr (std::is_trivially_copyable_v<T>) {
      // Readers of the ring take it in their own cycle: no call, no wake-up, no system call.
      if (ring_writer_) ring_writer_->write(std::as_bytes(std::span(&value, 1)));
    }
    for (std::size_t i = 0; i < subs_.size();) {
      auto& sub = static_cast<TypedSubscription&>(*subs_[i]);
      if (sub.kind == ConnKind::shared_memory) {
        bump(sub.pushed);  // in the ring: the reader counts what it skips
        bump(ring_pushed_);
      } else if (sub.direct) {
        if (!deliver_direct(sub, value)) {
          retire_locked(i);
          continue;
        }
      } else if (const std::uint64_t seq = queue_or_take(sub, value, call_count < call_limit); seq != 0) {
        calls[call_count++] = {&sub, seq};
      }
      ++i;
    }
  }
  if (call_count > 0 && !timed) {
    timed = true;
    start_ns = monotonic_ns();
  }
  const std::int64_t budget_ns = std::int64_t{options_.writer_call_timeout_ms} * 1'000'000;
  for (std::size_t k = 0; k < call_count; ++k) {
    TypedSubscription& sub = *calls[k].sub;
    if (budget_ns > 0 && monotonic_ns() - start_ns >= budget_ns) {
      hand_to_thread(sub, value);  // write() has spent its budget: no call begins after it
      continue;
    }
    bool dead = false;
    const bool delivered = guarded_call(sub, [&] { call_remote(sub, value, true, calls[k].seq); }, &dead);
    if (delivered) by_writer_.fetch_add(1, std::memory_order_relaxed);
    finish_writer_call(sub, delivered, dead);
  }
  if (timed) write_cost_.record(monotonic_ns() - start_ns);
}

// An in-process subscriber filled by write() itself; false when it must be retired.
template <PortData T>
bool OutPort<T>::deliver_direct(TypedSubscription& sub, const T& value) {
  if (sub.check_active && !sub.local->active()) {
    // The InPort was deactivated: the same as OBJECT_NOT_EXIST from a remote one.
    return !count_failure(sub, "OBJECT_NOT_EXIST", true);
  }
  static_cast<InPort<T>*>(sub.local.in())->deliver(value);
  count_pushed(sub);
  return !sub.once();
}

// Queues value for the delivery thread (returns 0), or - when write() may call and the
// subscription is idle - takes the call on (in_flight set) and returns the datum's number.
template <PortData T>
std::uint64_t OutPort<T>::queue_or_take(TypedSubscription& sub, const T& value, bool may_call) {
  {
    std::lock_guard slot_lock(sub.slot_mu);
    // A once-subscription takes one datum at a time until one is delivered: the first written
    // after it was made, or the next when that one's delivery failed. It has no writer_port:
    // its thread makes the call, under the subscription's bound, not write() under its own.
    if (sub.once() && (sub.done || sub.in_flight || sub.written_seq != sub.delivered_seq)) return 0;
    const bool idle = !sub.in_flight && sub.written_seq == sub.delivered_seq;
    if (may_call && idle && sub.writer_may_call && !CORBA::is_nil(sub.writer_port)) {
      sub.in_flight = true;
      sub.writer_calling = true;
      ++sub.delivered_seq;
      return ++sub.written_seq;
    }
    sub.ring[sub.written_seq % sub.ring.size()] = value;
    ++sub.written_seq;
  }
  sub.slot_cv.notify_one();
  return 0;
}

// A call write() took on but will not make: the datum goes to the delivery thread after all.
template <PortData T>
void OutPort<T>::hand_to_thread(TypedSubscription& sub, const T& value) {
  {
    std::lock_guard slot_lock(sub.slot_mu);
    sub.ring[(sub.written_seq - 1) % sub.ring.size()] = value;
    --sub.delivered_seq;
    sub.in_flight = false;
    sub.writer_calling = false;
    sub.slot_cv.notify_all();  // under the lock: once it is released, sub may be freed
  }
}

// Datum number seq to a remote subscriber: by_writer selects write()'s own references. An
// InPortOrdered is told the subscription's sender number and seq, so that a datum that
// arrives after a later one (behind a call that timed out) is dropped there, not taken.
template <PortData T>
void OutPort<T>::call_remote(TypedSubscription& sub, const T& value, bool by_writer, std::uint64_t seq) {
  CORBA::Any any;
  any <<= value;
  RTM::InPortOrdered_ptr ordered = by_writer ? sub.writer_port_ordered.in() : sub.port_ordered.in();
  if (!CORBA::is_nil(ordered)) {
    if (options_.oneway) ordered->push_in_order(any, sub.sender, seq);
    else ordered->put_in_order(any, sub.sender, seq);
    return;
  }
  RTM::InPortEx_ptr ex = by_writer ? sub.writer_port_ex.in() : sub.port_ex.in();
  if (options_.oneway && !CORBA::is_nil(ex)) ex->push(any);
  else (by_writer ? sub.writer_port.in() : sub.port.in())->put(any);
}

template <PortData T>
bool OutPort<T>::latest(T& out) const {
  std::lock_guard lock(mu_);
  if (!has_latest_) return false;
  out = latest_;
  return true;
}

template <PortData T>
std::unique_ptr<typename OutPort<T>::TypedSubscription> OutPort<T>::new_subscription(const ConnPolicy& asked) const {
  auto sub = std::make_unique<TypedSubscription>();
  sub->asked = asked;
  sub->policy = resolve(asked);
  sub->ring.resize(std::max<std::uint32_t>(sub->policy.depth, 1));
  return sub;
}

template <PortData T>
void OutPort<T>::deliver_slot(Subscription& base, std::uint64_t seq,
                              std::unique_lock<std::mutex>& slot_lock) {
  auto& sub = static_cast<TypedSubscription&>(base);
  sub.sending = sub.ring[(seq - 1) % sub.ring.size()];
  slot_lock.unlock();
  struct Relock {
    std::unique_lock<std::mutex>& lock;
    ~Relock() { lock.lock(); }
  } relock{slot_lock};
  if (sub.local.in() != nullptr) {
    if (sub.check_active && !sub.local->active()) throw CORBA::OBJECT_NOT_EXIST(0, CORBA::COMPLETED_NO);
    static_cast<InPort<T>*>(sub.local.in())->deliver(sub.sending);
    return;
  }
  call_remote(sub, sub.sending, false, seq);
}

template <PortData T>
bool OutPort<T>::connect(InPort<T>& in, const ConnPolicy& policy) {
  reap_retired();
  if (!depth_allowed(policy)) return false;
  auto sub = new_subscription(policy);
  in._add_ref();
  sub->local = &in;
  sub->peer = in.full_name();
  sub->kind = ConnKind::in_process;
  sub->direct = in.stores_without_waiting();
  sub->check_active = false;
  if (!reader_matches(*sub, &in)) return false;
  const bool threaded = !sub->direct;
  std::string why;
  if (!add_subscription(std::move(sub), threaded, why)) {
    refuse(why);
    return false;
  }
  return true;
}

template <PortData T>
bool OutPort<T>::disconnect(InPort<T>& in) {
  return remove_matching([&](const Subscription& s) { return s.local.in() == &in; });
}

template <PortData T>
CORBA::Any* OutPort<T>::get() {
  auto* any = new CORBA::Any;
  {
    std::lock_guard lock(mu_);
    if (has_latest_) {
      *any <<= latest_;
      return any;
    }
  }
  delete any;
  if (!get_before_data_logged_.exchange(true))
    log().warn("get on {} before its first write: raising BAD_INV_ORDER (minor {:#x})", full_name(),
               kMinorNoDataYet);
  throw CORBA::BAD_INV_ORDER(kMinorNoDataYet, CORBA::COMPLETED_NO);
}

template <PortData T>
bool OutPort<T>::offer_ring(TypedSubscription& sub) {
  if constexpr (!std::is_trivially_copyable_v<T>) {
    return false;
  } else {
    if (CORBA::is_nil(sub.port_ex)) return false;  // a 2004 InPort: CORBA
    try {
      sub.port_shm = RTM::InPortShm::_narrow(sub.port.in());
    } catch (const CORBA::Exception&) {
      return false;
    }
    if (CORBA::is_nil(sub.port_shm)) return false;
    omniORB::setClientCallTimeout(sub.port_shm.in(), options_.call_timeout_ms);
    std::string name;
    {
      std::lock_guard make(ring_mu_);
      if (!ring_segment_) {
        const ShmRingShape shape{std::max({2 * options_.queue_depth, kMinRingSlots, sub.policy.depth}), sizeof(T),
                                 ring_type_id<T>()};
        try {
          ShmSegment segment = ShmSegment::create(shm_ring_bytes(shape), full_name());
          std::lock_guard lock(mu_);
          ring_writer_.emplace(segment.data(), segment.size(), shape);
          ring_segment_.emplace(std::move(segment));
          ring_slots_ = shape.slots;
        } catch (const std::exception& e) {
          log().warn("{}: no shared-memory ring ({}): subscribers on this host get CORBA", full_name(), e.what());
          return false;
        }
      }
      // A ring made for shallower subscriptions cannot keep what this one may fall behind by.
      if (ring_slots_ < sub.policy.depth) {
        log().debug("{} -> {}: CORBA, not shared memory: depth {} is above the ring's {} slots", full_name(),
                    sub.peer, sub.policy.depth, ring_slots_);
        return false;
      }
      name = ring_segment_->name();
    }
    static const std::string host = shm_host_identity();
    static const long pid = ::getpid();
    static const unsigned long long start = process_start_ticks(pid);
    CORBA::String_var why;
    try {
      if (!sub.port_shm->attach_ring(name.c_str(), host.c_str(), ring_type_id<T>(), pid, start, why.out())) {
        log().debug("{} -> {}: CORBA, not shared memory: {}", full_name(), sub.peer, why.in());
        return false;
      }
    } catch (const CORBA::Exception& e) {
      log().debug("{} -> {}: CORBA, not shared memory: attach_ring raised {}", full_name(), sub.peer, e._name());
      return false;
    }
    sub.kind = ConnKind::shared_memory;
    sub.segment = name;
    return true;
  }
}

template <PortData T>
CORBA::Boolean OutPort<T>::subscribe(RTM::ReqType r_type, RTM::InPort_ptr i_port) {
  return subscribe_with(r_type == RTM::once ? ConnPolicy::one_shot() : ConnPolicy::repeated(), i_port);
}

template <PortData T>
CORBA::Boolean OutPort<T>::connect(const RTM::ConnPolicy& policy, RTM::InPort_ptr i_port) {
  ConnPolicy asked;
  try {
    asked = from_idl(policy);
  } catch (const std::invalid_argument& e) {
    refuse(full_name() + ": " + e.what());
    return false;
  }
  return subscribe_with(asked, i_port);
}

template <PortData T>
bool OutPort<T>::subscribe_with(const ConnPolicy& policy, RTM::InPort_ptr i_port) {
  reap_retired();
  if (CORBA::is_nil(i_port)) {
    refuse(full_name() + ": nil InPort reference");
    return false;
  }
  if (!depth_allowed(policy)) return false;
  // A full port refuses before any remote call; add_subscription() checks again under its lock.
  if (subscription_count() >= options_.max_subscriptions) {
    refuse(full_name() + ": " + full_port_text());
    return false;
  }
  auto sub = new_subscription(policy);
  sub->port = RTM::InPort::_duplicate(i_port);
  const std::uint32_t call_timeout_ms = sub->policy.call_timeout_ms;
  // Remote calls: made before any lock is taken, each bounded (an InPort that never answers
  // must not hold this upcall, and the component's shutdown, for ever).
  omniORB::setClientCallTimeout(i_port, call_timeout_ms);
  CORBA::TypeCode_var their_type;
  try {
    sub->peer = peer_name(i_port, call_timeout_ms);
    their_type = i_port->port_type();
    sub->port_ex = RTM::InPortEx::_narrow(i_port);
    if (!CORBA::is_nil(sub->port_ex)) sub->port_ordered = RTM::InPortOrdered::_narrow(i_port);
  } catch (const CORBA::Exception& e) {
    refuse(full_name() + " -> " + (sub->peer.empty() ? std::string("<InPort>") : sub->peer) +
           ": the InPort does not answer (" + e._name() + ")");
    return false;
  }
  if (!their_type->equivalent(type_code())) {
    refuse(full_name() + " (" + type_name(type_code()) + ") -> " + sub->peer + " (" + type_name(their_type.in()) +
           "): types differ");
    return false;
  }
  if (options_.in_process) {
    PortableServer::Servant_var<InPortBase> local = InPortBase::find_local(i_port);
    if (local.in() != nullptr && local->data_type() == typeid(T)) {
      sub->direct = local->stores_without_waiting();
      sub->kind = ConnKind::in_process;
      sub->local = local._retn();
    }
  }
  if (!reader_matches(*sub, sub->local.in())) return false;
  if (sub->local.in() == nullptr) {
    omniORB::setClientCallTimeout(sub->port.in(), call_timeout_ms);
    if (!CORBA::is_nil(sub->port_ex)) omniORB::setClientCallTimeout(sub->port_ex.in(), call_timeout_ms);
    if (!admitted(*sub)) return false;
    if (shared_memory() && !sub->policy.corba_only && !sub->once() && offer_ring(*sub)) {
      RTM::InPortShm_var reader = sub->port_shm;
      const std::string segment = sub->segment;
      std::string why;
      if (add_subscription(std::move(sub), true, why)) return true;
      detach_quietly(reader.in(), segment);  // a duplicate or a full port: its attach is undone
      refuse(why);
      return false;
    }
    if (!CORBA::is_nil(sub->port_ordered)) {
      omniORB::setClientCallTimeout(sub->port_ordered.in(), call_timeout_ms);
      sub->sender = random_sender();
    }
    // A once-subscription is served by its thread alone (resolve() says so): write() gets no
    // reference of its own to it.
    sub->kind = ConnKind::remote_by_thread;
    if (sub->policy.delivery == ConnPolicy::Delivery::writer_when_idle) {
      make_writer_references(*sub);
      if (!CORBA::is_nil(sub->writer_port)) sub->kind = ConnKind::remote_by_writer;
    }
  }
  const bool threaded = !sub->direct;
  std::string why;
  if (!add_subscription(std::move(sub), threaded, why)) {
    refuse(why);
    return false;
  }
  return true;
}

}  // namespace rtm
