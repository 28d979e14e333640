// SPDX-License-Identifier: Apache-2.0
#include "rtm/connection.h"

#include "rt/thread.h"
#include "rtm/data.h"
#include "rtm/log.h"
#include "rtm/orb.h"

#include <pthread.h>

#include <random>

namespace rtm {

Connection::Connection(ConnectionHost& host, ConnKind kind, Subscriber who)
    : host_(host), kind_(kind), who_(std::move(who)) {}

void Connection::start() {
  if (!has_thread()) return;
  thread_ = std::thread([this] { run(); });
  // Named here, not by the thread itself: whoever lists the threads once subscribe() has returned sees the
  // name and the priority. Data pass a delivery thread on their way to the subscriber: with real-time
  // priorities on it runs at the path's (rt/thread.h), as the thread of the put that receives them does.
  pthread_setname_np(thread_.native_handle(), "rtm-deliver");
  if (const int priority = path_thread_priority(); priority > 0 && carries_data())
    set_thread_fifo_priority(thread_.native_handle(), priority);
}

bool Connection::stop_and_join() {
  {
    std::unique_lock slot_lock(slot_mu_);
    stop_ = true;
    slot_cv_.notify_all();
    wait_for_writer(slot_lock);
  }
  if (thread_.joinable()) {
    if (thread_.get_id() == std::this_thread::get_id()) return false;
    thread_.join();
  }
  stopped();
  return true;
}

void Connection::detach_thread() {
  if (thread_.joinable()) thread_.detach();
}

bool Connection::same_subscriber(const Connection& other) const {
  const bool same_local = who_.local.in() != nullptr && who_.local.in() == other.who_.local.in();
  const bool same_ref = !CORBA::is_nil(who_.port) && !CORBA::is_nil(other.who_.port) &&
                        who_.port->_is_equivalent(other.who_.port.in());
  return same_local || same_ref;
}

bool Connection::is(bool once, RTM::InPort_ptr port, const InPortBase* local) const {
  if (this->once() != once) return false;
  if (!CORBA::is_nil(who_.port)) return static_cast<bool>(who_.port->_is_equivalent(port));
  return local != nullptr && who_.local.in() == local;
}

void Connection::describe(RTM::SubscriptionInfo& info) const {
  info.req_type = once() ? RTM::once : RTM::repeated;
  info.subscriber = RTM::InPort::_duplicate(who_.port.in());
  info.peer = CORBA::string_dup(who_.peer.c_str());
  info.in_process = kind_ == ConnKind::in_process;
  info.path = CORBA::string_dup(info.in_process                        ? "in-process"
                                : kind_ == ConnKind::shared_memory ? "shared memory"
                                                                   : "CORBA");
  info.kind = CORBA::string_dup(to_string(kind_));
  info.asked = to_idl(who_.asked);
  info.policy = to_idl(who_.policy);
  info.reader = CORBA::string_dup(who_.reader.c_str());
  info.pushed = pushed_.load(std::memory_order_relaxed);
  info.dropped = dropped_.load(std::memory_order_relaxed);
  info.failures = failures_.load(std::memory_order_relaxed);
  const char* failure = failure_name_.load(std::memory_order_relaxed);
  const std::uint32_t refused = refused_minor_.load(std::memory_order_relaxed);
  const std::string why = !failure ? "" : refused ? std::string(failure) + ": " + access_refusal_text(refused) : failure;
  info.last_failure = CORBA::string_dup(why.c_str());
}

bool Connection::count_failure(const char* exception_name, bool dead_kind, std::uint32_t refused_minor) {
  host_.failed.fetch_add(1, std::memory_order_relaxed);
  failure_name_.store(exception_name, std::memory_order_relaxed);
  refused_minor_.store(refused_minor, std::memory_order_relaxed);
  const std::uint32_t failures = failures_.fetch_add(1, std::memory_order_relaxed) + 1;
  if (dead_kind && failures >= host_.max_failures) {
    log().warn("{} -> {}: dropped after {} consecutive failed deliveries ({})", host_.name, who_.peer, failures,
               exception_name);
    return true;
  }
  if (!failure_logged_) {
    failure_logged_ = true;
    log().warn("{} -> {}: delivery raised {} (further failures are only counted)", host_.name, who_.peer,
               exception_name);
  }
  return false;
}

void Connection::count_pushed() {
  failures_.store(0, std::memory_order_relaxed);
  failure_name_.store(nullptr, std::memory_order_relaxed);
  pushed_.fetch_add(1, std::memory_order_relaxed);
  host_.pushed.fetch_add(1, std::memory_order_relaxed);
}

void Connection::leave() {
  {
    std::lock_guard slot_lock(slot_mu_);
    done_ = true;
  }
  host_.retire(this);
}

void detach_quietly(RTM::InPortShm_ptr reader, const std::string& segment) {
  if (CORBA::is_nil(reader)) return;
  try {
    reader->detach_ring(segment.c_str());
  } catch (const CORBA::Exception& e) {
    log().debug("detach_ring({}) raised {}: the subscriber is gone or busy", segment, e._name());
  }
}

WriterReferences make_writer_references(const Subscriber& who, std::uint32_t writer_call_timeout_ms, bool oneway) {
  WriterReferences refs;
  Orb* orb = Orb::instance();
  if (orb == nullptr) return refs;  // the thread delivers
  // A reference of write()'s own, unmarshalled anew (omniORB keeps call timeouts per reference).
  CORBA::String_var ior = orb->orb()->object_to_string(who.port.in());
  CORBA::Object_var copy = orb->orb()->string_to_object(ior.in());
  // One round trip on it under the long bound first: the first call through a reference runs code and touches
  // memory no later call does, and on a loaded machine outlived the short bound (the first datum then failed
  // as TIMEOUT). A subscriber that does not answer here is found out by the first write() as before.
  omniORB::setClientCallTimeout(copy.in(), who.policy.call_timeout_ms);
  try {
    (void)copy->_non_existent();
  } catch (const CORBA::Exception&) {
  }
  // A timeout of 0 is omniORB's "none" too.
  if (oneway && !CORBA::is_nil(who.port_ex)) {
    refs.port_ex = RTM::InPortEx::_unchecked_narrow(copy.in());
    omniORB::setClientCallTimeout(refs.port_ex.in(), writer_call_timeout_ms);
  }
  if (!CORBA::is_nil(who.port_ordered)) {
    refs.port_ordered = RTM::InPortOrdered::_unchecked_narrow(copy.in());
    omniORB::setClientCallTimeout(refs.port_ordered.in(), writer_call_timeout_ms);
  }
  refs.port = RTM::InPort::_unchecked_narrow(copy.in());
  omniORB::setClientCallTimeout(refs.port.in(), writer_call_timeout_ms);
  return refs;
}

std::uint64_t random_sender() {
  std::random_device random;
  return (std::uint64_t{random()} << 32) ^ random();
}

}  // namespace rtm
