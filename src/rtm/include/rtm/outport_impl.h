// SPDX-License-Identifier: Apache-2.0
// Template definitions of rtm/outport.h; include that header, not this one.
#pragma once

#include "rt/clock.h"
#include "rtm/data.h"
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
  // Here, not in ~OutPortBase: the ring's readers are told to detach before its segment goes.
  close();
}

template <PortData T>
std::unique_ptr<PortTap> OutPort<T>::tap(TapSink* sink, std::uint16_t key, std::uint32_t capacity) {
  return make_tap(sink, key, capacity, tap_);
}

template <PortData T>
void OutPort<T>::write(const T& value) {
  if constexpr (Stamped<T>) {
    if (derives_stamp()) {
      if (const std::int64_t stamp = derived_stamp_ns(); stamp != 0) {
        restamped_ = value;
        restamped_.tm = from_ns(stamp);
        publish(restamped_);
        return;
      }
    }
  }
  publish(value);
}

template <PortData T>
void OutPort<T>::publish(const T& value) {
  if (tap_ != nullptr) [[unlikely]] {
    if (tap_->replaying()) {
      tap_->replay_write(value);
      return;
    }
    tap_->logged_write(value);
  }
  // Timed always when it may call or queue, else one call in kWriteCostSampling (WriteCost).
  // The counter is read before the lock: a subscription made meanwhile is seen below.
  bool timed = calling_connections_.load(std::memory_order_relaxed) != 0 ||
               written_.load(std::memory_order_relaxed) % kWriteCostSampling == 0;
  std::int64_t start_ns = timed ? monotonic_ns() : 0;
  // Connections write() makes a call for itself, after its lock is released (fixed capacity: no allocation).
  struct Call {
    TypedConnection<T>* connection;
    std::uint64_t seq;
  };
  std::array<Call, kMaxWriterCalls> calls;
  std::size_t call_count = 0;
  const std::size_t call_limit = std::min<std::size_t>(options_.writer_calls, kMaxWriterCalls);
  {
    std::lock_guard lock(mu_);
    latest_ = value;
    has_latest_ = true;
    // Only write() changes it, under mu_: a store, not a locked add, per datum.
    written_.store(written_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
    if constexpr (std::is_trivially_copyable_v<T>) {
      // Readers of the ring take it in their own cycle: no call, no wake-up, no system call.
      if (ring_writer_) ring_writer_->write(std::as_bytes(std::span(&value, 1)));
    }
    for (std::size_t i = 0; i < conns_.size();) {
      auto& connection = static_cast<TypedConnection<T>&>(*conns_[i]);
      const auto push = connection.push(value, call_count < call_limit);
      if (push.retire) {
        retire_locked(i);
        continue;
      }
      if (push.call_seq != 0) calls[call_count++] = {&connection, push.call_seq};
      ++i;
    }
  }
  if (call_count > 0 && !timed) {
    timed = true;
    start_ns = monotonic_ns();
  }
  const std::int64_t budget_ns = std::int64_t{options_.writer_call_timeout_ms} * 1'000'000;
  for (std::size_t k = 0; k < call_count; ++k)
    calls[k].connection->writer_call(value, calls[k].seq, budget_ns <= 0 || monotonic_ns() - start_ns < budget_ns);
  if (timed) write_cost_.record(monotonic_ns() - start_ns);
}

template <PortData T>
bool OutPort<T>::latest(T& out) const {
  std::lock_guard lock(mu_);
  if (!has_latest_) return false;
  out = latest_;
  return true;
}

template <PortData T>
bool OutPort<T>::connect(InPort<T>& in, const ConnPolicy& policy) {
  reap_retired();
  if (!depth_allowed(policy)) return false;
  Subscriber who;
  who.asked = policy;
  who.policy = resolve(policy);
  in._add_ref();
  who.local = &in;
  who.peer = in.full_name();
  who.check_active = false;
  if (!reader_matches(who)) return false;
  return add_connection(make_connection(std::move(who)));
}

template <PortData T>
bool OutPort<T>::disconnect(InPort<T>& in) {
  return remove_matching([&](const Connection& c) { return c.subscriber().local.in() == &in; });
}

template <PortData T>
bool OutPort<T>::connect_local(InPortBase& in, const ConnPolicy& policy) {
  auto* typed = dynamic_cast<InPort<T>*>(&in);
  if (!typed) {
    refuse_types(in.full_name(), in.type_code());
    return false;
  }
  return connect(*typed, policy);
}

template <PortData T>
bool OutPort<T>::disconnect_local(InPortBase& in) {
  auto* typed = dynamic_cast<InPort<T>*>(&in);
  return typed && disconnect(*typed);
}

template <PortData T>
CORBA::Any* OutPort<T>::get() {
  auto* any = new CORBA::Any;
  {
    std::lock_guard lock(mu_);
    if (has_latest_) {
      DataTraits<T>::insert(*any, latest_);
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
bool OutPort<T>::offer_ring(const Subscriber& who, RTM::InPortShm_var& reader, std::string& segment) {
  if constexpr (!std::is_trivially_copyable_v<T>) {
    return false;
  } else {
    if (CORBA::is_nil(who.port_ex)) return false;  // a 2004 InPort: CORBA
    try {
      reader = RTM::InPortShm::_narrow(who.port.in());
    } catch (const CORBA::Exception&) {
      return false;
    }
    if (CORBA::is_nil(reader)) return false;
    omniORB::setClientCallTimeout(reader.in(), options_.call_timeout_ms);
    std::string name;
    {
      std::lock_guard make(ring_mu_);
      if (!ring_segment_) {
        const ShmRingShape shape{std::max({2 * options_.queue_depth, kMinRingSlots, who.policy.depth}), sizeof(T),
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
      if (ring_slots_ < who.policy.depth) {
        log().debug("{} -> {}: CORBA, not shared memory: depth {} is above the ring's {} slots", full_name(),
                    who.peer, who.policy.depth, ring_slots_);
        return false;
      }
      name = ring_segment_->name();
    }
    static const std::string host = shm_host_identity();
    static const long pid = ::getpid();
    static const unsigned long long start = process_start_ticks(pid);
    CORBA::String_var why;
    try {
      if (!reader->attach_ring(name.c_str(), host.c_str(), ring_type_id<T>(), pid, start, why.out())) {
        log().debug("{} -> {}: CORBA, not shared memory: {}", full_name(), who.peer, why.in());
        return false;
      }
    } catch (const CORBA::Exception& e) {
      log().debug("{} -> {}: CORBA, not shared memory: attach_ring raised {}", full_name(), who.peer, e._name());
      return false;
    }
    segment = name;
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
  // A full port refuses before any remote call; add_connection() checks again under its lock.
  if (subscription_count() >= options_.max_subscriptions) {
    refuse(full_name() + ": " + full_port_text());
    return false;
  }
  Subscriber who;
  who.asked = policy;
  who.policy = resolve(policy);
  who.port = RTM::InPort::_duplicate(i_port);
  if (!negotiate(who, i_port)) return false;
  return add_connection(make_connection(std::move(who)));
}

template <PortData T>
bool OutPort<T>::negotiate(Subscriber& who, RTM::InPort_ptr i_port) {
  const std::uint32_t call_timeout_ms = who.policy.call_timeout_ms;
  // Remote calls: made before any lock is taken, each bounded (an InPort that never answers
  // must not hold this upcall, and the component's shutdown, for ever).
  omniORB::setClientCallTimeout(i_port, call_timeout_ms);
  CORBA::TypeCode_var their_type;
  try {
    who.peer = peer_name(i_port, call_timeout_ms);
    their_type = i_port->port_type();
    who.port_ex = RTM::InPortEx::_narrow(i_port);
    if (!CORBA::is_nil(who.port_ex)) who.port_ordered = RTM::InPortOrdered::_narrow(i_port);
  } catch (const CORBA::Exception& e) {
    refuse(full_name() + " -> " + (who.peer.empty() ? std::string("<InPort>") : who.peer) +
           ": the InPort does not answer (" + e._name() + ")");
    return false;
  }
  if (!their_type->equivalent(type_code())) {
    refuse_types(who.peer, their_type.in());
    return false;
  }
  if (options_.in_process) {
    PortableServer::Servant_var<InPortBase> local = InPortBase::find_local(i_port);
    if (local.in() != nullptr && local->data_type() == typeid(T)) who.local = local._retn();
  }
  if (!reader_matches(who)) return false;
  if (who.local.in() != nullptr) return true;
  omniORB::setClientCallTimeout(who.port.in(), call_timeout_ms);
  if (!CORBA::is_nil(who.port_ex)) omniORB::setClientCallTimeout(who.port_ex.in(), call_timeout_ms);
  if (!CORBA::is_nil(who.port_ordered)) omniORB::setClientCallTimeout(who.port_ordered.in(), call_timeout_ms);
  return admitted(who);
}

template <PortData T>
std::unique_ptr<Connection> OutPort<T>::make_connection(Subscriber who) {
  if (who.local.in() != nullptr) {
    if (who.local->stores_without_waiting()) return std::make_unique<DirectConnection<T>>(host_, std::move(who));
    return std::make_unique<QueuedConnection<T>>(host_, std::move(who));
  }
  RTM::InPortShm_var reader;
  std::string segment;
  if (shared_memory() && !who.policy.corba_only && !who.policy.once && offer_ring(who, reader, segment)) {
    // Refused later (a duplicate, a full port), it is stopped as any other: its attach undone.
    return std::make_unique<RingConnection<T>>(host_, std::move(who), std::move(reader), std::move(segment));
  }
  // A subscriber that cannot put data in order (no InPortOrdered: a 2004 client) is called by the
  // subscription's thread alone, one call after another under the long bound: write()'s own call, bounded
  // short, may time out yet arrive after the next datum, which such a subscriber would keep as the newer.
  if (who.policy.delivery == ConnPolicy::Delivery::writer_when_idle && CORBA::is_nil(who.port_ordered))
    who.policy.delivery = ConnPolicy::Delivery::thread;
  const bool by_writer = who.policy.delivery == ConnPolicy::Delivery::writer_when_idle;
  return std::make_unique<RemoteConnection<T>>(host_, std::move(who), by_writer);
}

}  // namespace rtm
