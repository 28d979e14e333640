// SPDX-License-Identifier: Apache-2.0
#include "rtm/outport.h"

#include "rt/thread.h"

#include "rtm/access.h"

#include "rtm/log.h"
#include "rtm/orb.h"

#include <pthread.h>

#include <chrono>
#include <random>
#include <stdexcept>

namespace rtm {

OutPortBase::OutPortBase(std::string name, std::string owner, OutPortOptions options)
    : name_(std::move(name)), owner_(std::move(owner)), options_(options), delivery_(options.delivery), shared_memory_(options.shared_memory) {
  if (name_.empty()) throw std::invalid_argument("OutPort: empty port name (owner '" + owner_ + "')");
  if (options_.max_failures == 0) throw std::invalid_argument("OutPort " + full_name() + ": max_failures must be >= 1");
  if (options_.max_subscriptions == 0)
    throw std::invalid_argument("OutPort " + full_name() + ": max_subscriptions must be >= 1");
}

OutPortBase::~OutPortBase() { close(); }

std::string OutPortBase::full_name() const { return owner_ + "." + name_; }

OutPortCounters OutPortBase::counters_snapshot() const {
  OutPortCounters c;
  c.written = written_.load(std::memory_order_relaxed);
  c.refused = refused_.load(std::memory_order_relaxed);
  c.dropped = dropped_.load(std::memory_order_relaxed);
  c.pushed = pushed_.load(std::memory_order_relaxed) + ring_pushed_.load(std::memory_order_relaxed);
  c.failed = failed_.load(std::memory_order_relaxed);
  c.timed_out = timed_out_.load(std::memory_order_relaxed);
  c.by_writer = by_writer_.load(std::memory_order_relaxed);
  return c;
}

WriteCost OutPortBase::write_cost() const {
  WriteCost w;
  w.count = write_cost_.count();
  w.p50_ns = write_cost_.percentile_ns(0.5);
  w.p99_ns = write_cost_.percentile_ns(0.99);
  w.max_ns = write_cost_.max_ns();
  return w;
}

std::string OutPortBase::last_refusal() const {
  std::lock_guard lock(mu_);
  return last_refusal_;
}

std::string OutPortBase::full_port_text() const {
  return "already " + std::to_string(options_.max_subscriptions) +
         " subscriptions, the most it takes (OutPortOptions::max_subscriptions)";
}

std::size_t OutPortBase::subscription_count() const {
  std::lock_guard lock(mu_);
  return subs_.size();
}

RTM::OutPortEx_ptr OutPortBase::activate(Orb& orb) {
  std::lock_guard lock(ref_mu_);
  if (CORBA::is_nil(ref_)) {
    CORBA::Object_var obj = orb.activate(this);
    ref_ = RTM::OutPortEx::_narrow(obj);
    orb_ = &orb;
  }
  return RTM::OutPortEx::_duplicate(ref_.in());
}

void OutPortBase::deactivate() {
  Orb* orb = nullptr;
  {
    std::lock_guard lock(ref_mu_);
    if (CORBA::is_nil(ref_)) return;
    ref_ = RTM::OutPortEx::_nil();
    orb = orb_;
    orb_ = nullptr;
  }
  // After the Orb is gone its POA has already released every servant.
  if (Orb::instance() == orb) orb->deactivate(this);
}

RTM::OutPortEx_ptr OutPortBase::reference() const {
  std::lock_guard lock(ref_mu_);
  return RTM::OutPortEx::_duplicate(ref_.in());
}

void OutPortBase::stop_and_join(std::unique_ptr<Subscription> sub,
                                std::vector<std::unique_ptr<Subscription>>& parked) {
  {
    std::unique_lock slot_lock(sub->slot_mu);
    sub->stop = true;
    sub->slot_cv.notify_all();
    // A call write() took on is made with no lock held: it must end before sub goes (the
    // delivery thread's own call ends before the join below).
    sub->slot_cv.wait(slot_lock, [&] { return !sub->writer_calling; });
  }
  if (sub->thread.joinable()) {
    // A delivery thread that unsubscribes itself (e.g. from a callback) cannot join itself.
    if (sub->thread.get_id() == std::this_thread::get_id()) {
      parked.push_back(std::move(sub));
      return;
    }
    sub->thread.join();
  }
  if (sub->kind == ConnKind::shared_memory) detach_quietly(sub->port_shm.in(), sub->segment);
}

void OutPortBase::close() {
  std::vector<std::unique_ptr<Subscription>> all;
  {
    std::lock_guard lock(mu_);
    closed_ = true;
    for (auto& s : subs_) all.push_back(std::move(s));
    for (auto& s : retired_) all.push_back(std::move(s));
    subs_.clear();
    retired_.clear();
    subs_changed_locked();
  }
  std::vector<std::unique_ptr<Subscription>> parked;
  for (auto& s : all) stop_and_join(std::move(s), parked);
  for (auto& s : parked) s->thread.detach();
}

void OutPortBase::reap_retired() {
  std::vector<std::unique_ptr<Subscription>> dead;
  {
    std::lock_guard lock(mu_);
    dead.swap(retired_);
  }
  std::vector<std::unique_ptr<Subscription>> parked;
  for (auto& s : dead) stop_and_join(std::move(s), parked);
  if (!parked.empty()) {
    std::lock_guard lock(mu_);
    for (auto& s : parked) retired_.push_back(std::move(s));
  }
}

bool OutPortBase::add_subscription(std::unique_ptr<Subscription> sub, bool start_thread, std::string& why) {
  std::lock_guard lock(mu_);
  if (closed_) {
    why = full_name() + " -> " + sub->peer + ": the OutPort is closed";
    return false;
  }
  if (subs_.size() >= options_.max_subscriptions) {
    why = full_name() + " -> " + sub->peer + ": " + full_port_text();
    return false;
  }
  for (const auto& existing : subs_) {
    const bool same_local = existing->local.in() && sub->local.in() && existing->local.in() == sub->local.in();
    const bool same_ref = !CORBA::is_nil(existing->port) && !CORBA::is_nil(sub->port) &&
                          existing->port->_is_equivalent(sub->port.in());
    if (same_local || same_ref) {
      why = full_name() + " -> " + sub->peer + ": already subscribed";
      return false;
    }
  }
  Subscription* raw = sub.get();
  subs_.push_back(std::move(sub));
  subs_changed_locked();
  if (start_thread) {
    raw->thread = std::thread(&OutPortBase::delivery_loop, this, raw);
    // Named here, not by the thread itself: whoever lists the threads once subscribe() has
    // returned sees the name, as it sees the priority set below.
    pthread_setname_np(raw->thread.native_handle(), "rtm-deliver");
    // Data pass a delivery thread on their way to the subscriber: with real-time priorities
    // on it runs at the path's (rt/thread.h), as the thread of the put that receives them
    // does; set before subscribe() returns. A ring's probe thread carries no datum.
    if (const int priority = path_thread_priority(); priority > 0 && raw->kind != ConnKind::shared_memory)
      set_thread_fifo_priority(raw->thread.native_handle(), priority);
  }
  return true;
}

bool OutPortBase::remove_matching(const std::function<bool(const Subscription&)>& match) {
  reap_retired();
  std::vector<std::unique_ptr<Subscription>> victims;
  {
    std::lock_guard lock(mu_);
    for (std::size_t i = 0; i < subs_.size();) {
      if (match(*subs_[i])) {
        victims.push_back(std::move(subs_[i]));
        subs_.erase(subs_.begin() + static_cast<std::ptrdiff_t>(i));
      } else {
        ++i;
      }
    }
    subs_changed_locked();
  }
  std::vector<std::unique_ptr<Subscription>> parked;
  const bool removed = !victims.empty();
  for (auto& v : victims) stop_and_join(std::move(v), parked);
  if (!parked.empty()) {
    std::lock_guard lock(mu_);
    for (auto& s : parked) retired_.push_back(std::move(s));
  }
  return removed;
}

void OutPortBase::retire(Subscription* sub) {
  std::lock_guard lock(mu_);
  for (std::size_t i = 0; i < subs_.size(); ++i) {
    if (subs_[i].get() == sub) {
      retire_locked(i);
      return;
    }
  }
  // Not listed any more: unsubscribe() or close() took it and joins this thread.
}

void OutPortBase::retire_locked(std::size_t index) {
  retired_.push_back(std::move(subs_[index]));
  subs_.erase(subs_.begin() + static_cast<std::ptrdiff_t>(index));
  subs_changed_locked();
}

void OutPortBase::subs_changed_locked() {
  const auto calling = std::count_if(subs_.begin(), subs_.end(), [](const auto& s) {
    return s->kind != ConnKind::shared_memory && !s->direct;
  });
  calling_subscriptions_.store(static_cast<std::uint32_t>(calling), std::memory_order_relaxed);
}

bool OutPortBase::count_failure(Subscription& sub, const char* exception_name, bool dead_kind,
                                std::uint32_t refused_minor) {
  failed_.fetch_add(1, std::memory_order_relaxed);
  sub.failure_name.store(exception_name, std::memory_order_relaxed);
  sub.refused_minor.store(refused_minor, std::memory_order_relaxed);
  const std::uint32_t failures = sub.failures.fetch_add(1, std::memory_order_relaxed) + 1;
  if (dead_kind && failures >= options_.max_failures) {
    log().warn("{} -> {}: dropped after {} consecutive failed deliveries ({})", full_name(), sub.peer, failures,
               exception_name);
    return true;
  }
  if (!sub.failure_logged) {
    sub.failure_logged = true;
    log().warn("{} -> {}: delivery raised {} (further failures are only counted)", full_name(), sub.peer,
               exception_name);
  }
  return false;
}

void OutPortBase::delivery_loop(Subscription* sub) {
  if (sub->kind == ConnKind::shared_memory) {
    probe_loop(sub);
    return;
  }
  std::unique_lock lock(sub->slot_mu);
  for (;;) {
    // Not while write() makes a call for this subscription: data leave in order.
    sub->slot_cv.wait(lock, [&] { return sub->stop || (sub->written_seq != sub->delivered_seq && !sub->in_flight); });
    if (sub->stop) return;
    // Oldest first; what the ring no longer holds was overwritten: count it as dropped.
    const std::uint64_t behind = sub->written_seq - sub->delivered_seq;
    const std::uint64_t capacity = ring_size(*sub);
    if (behind > capacity) {
      const std::uint64_t missed = behind - capacity;
      sub->dropped.fetch_add(missed, std::memory_order_relaxed);
      dropped_.fetch_add(missed, std::memory_order_relaxed);
      sub->delivered_seq += missed;
    }
    const std::uint64_t seq = ++sub->delivered_seq;
    sub->in_flight = true;
    bool drop = false;
    const bool delivered = guarded_call(*sub, [&] { deliver_slot(*sub, seq, lock); }, &drop);
    sub->in_flight = false;
    if (delivered) {
      sub->writer_may_call = true;  // delivered: write() may call again
      drop = sub->once();
    }
    if (drop) {
      sub->done = true;
      lock.unlock();  // lock order: mu_ before slot_mu
      retire(sub);
      return;
    }
  }
}

void OutPortBase::count_pushed(Subscription& sub) {
  sub.failures.store(0, std::memory_order_relaxed);
  sub.failure_name.store(nullptr, std::memory_order_relaxed);
  sub.pushed.fetch_add(1, std::memory_order_relaxed);
  pushed_.fetch_add(1, std::memory_order_relaxed);
}

void OutPortBase::finish_writer_call(Subscription& sub, bool delivered, bool dead) {
  if (dead || (delivered && sub.once())) {
    {
      std::lock_guard slot_lock(sub.slot_mu);
      sub.done = true;
    }
    retire(&sub);  // still calling: sub stays until the flag below is cleared
  }
  {
    std::lock_guard slot_lock(sub.slot_mu);
    sub.in_flight = false;
    sub.writer_calling = false;
    // After a failure the thread takes the next data (a slow subscriber then costs write() no
    // more), until it has delivered again.
    if (!delivered) sub.writer_may_call = false;
    // Wake only whom this call held up: the delivery thread when data were queued meanwhile,
    // a stop_and_join() (stop set) waiting for the call to end. A wake-up nobody needs is a
    // context switch per datum (on a shared CPU, the price of a round trip). Notified before
    // the lock is released: once it is, a stop_and_join() may free sub.
    if (sub.stop || sub.written_seq != sub.delivered_seq) sub.slot_cv.notify_all();
  }
}

bool OutPortBase::admitted(Subscription& sub) {
  if (CORBA::is_nil(sub.port_ex)) return true;
  try {
    sub.port_ex->admit_writer();
  } catch (const CORBA::NO_PERMISSION& e) {
    refuse(full_name() + " -> " + sub.peer + ": " + access_refusal_text(e.minor()));
    return false;
  } catch (const CORBA::Exception&) {
    // Not answering now is found out by the first write(), as for any subscriber.
  }
  return true;
}

void OutPortBase::detach_quietly(RTM::InPortShm_ptr reader, const std::string& ring) {
  if (CORBA::is_nil(reader)) return;
  try {
    reader->detach_ring(ring.c_str());
  } catch (const CORBA::Exception& e) {
    log().debug("detach_ring({}) raised {}: the subscriber is gone or busy", ring, e._name());
  }
}

void OutPortBase::probe_loop(Subscription* sub) {
  std::unique_lock lock(sub->slot_mu);
  for (;;) {
    if (sub->slot_cv.wait_for(lock, std::chrono::seconds(1), [&] { return sub->stop; })) return;
    lock.unlock();
    bool gone = false;
    const char* failure = nullptr;
    try {
      gone = sub->port->_non_existent();
      if (gone) failure = "OBJECT_NOT_EXIST";
    } catch (const CORBA::TIMEOUT& e) {
      failure = e._name();  // busy, not gone: counted, never dropped for it
    } catch (const CORBA::Exception& e) {
      gone = true;
      failure = e._name();
    }
    bool drop = false;
    if (failure) {
      drop = count_failure(*sub, failure, gone);
    } else {
      sub->failures.store(0, std::memory_order_relaxed);
      sub->failure_name.store(nullptr, std::memory_order_relaxed);
    }
    lock.lock();
    if (drop) {
      sub->done = true;
      lock.unlock();
      retire(sub);
      return;
    }
  }
}

void OutPortBase::make_writer_references(Subscription& sub) const {
  Orb* orb = Orb::instance();
  if (orb == nullptr) return;  // the thread delivers
  // A reference of write()'s own, unmarshalled anew: omniORB keeps call timeouts per
  // reference, so the delivery thread's longer bound stays on sub.port.
  CORBA::String_var ior = orb->orb()->object_to_string(sub.port.in());
  CORBA::Object_var copy = orb->orb()->string_to_object(ior.in());
  // One round trip on it under the long bound first: the first call through a reference runs
  // code and touches memory no later call does, and on a loaded machine outlived the short
  // bound (the first datum then failed as TIMEOUT). A subscriber that does not answer here
  // is found out by the first write() as before.
  omniORB::setClientCallTimeout(copy.in(), sub.policy.call_timeout_ms);
  try {
    (void)copy->_non_existent();
  } catch (const CORBA::Exception&) {
  }
  // A timeout of 0 is omniORB's "none" too.
  if (options_.oneway && !CORBA::is_nil(sub.port_ex)) {
    sub.writer_port_ex = RTM::InPortEx::_unchecked_narrow(copy.in());
    omniORB::setClientCallTimeout(sub.writer_port_ex.in(), options_.writer_call_timeout_ms);
  }
  if (!CORBA::is_nil(sub.port_ordered)) {
    sub.writer_port_ordered = RTM::InPortOrdered::_unchecked_narrow(copy.in());
    omniORB::setClientCallTimeout(sub.writer_port_ordered.in(), options_.writer_call_timeout_ms);
  }
  sub.writer_port = RTM::InPort::_unchecked_narrow(copy.in());
  omniORB::setClientCallTimeout(sub.writer_port.in(), options_.writer_call_timeout_ms);
}

ConnPolicy OutPortBase::resolve(const ConnPolicy& asked) const {
  ConnPolicy p = asked;
  if (p.depth == 0) p.depth = std::max<std::uint32_t>(options_.queue_depth, 1);
  if (p.call_timeout_ms == 0) p.call_timeout_ms = options_.call_timeout_ms;
  if (p.delivery == ConnPolicy::Delivery::port_default)
    p.delivery = delivery() == OutPortOptions::Delivery::thread ? ConnPolicy::Delivery::thread
                                                                 : ConnPolicy::Delivery::writer_when_idle;
  // A once-subscription is served by its thread, under the call bound (OutPortOptions::delivery).
  if (p.once) p.delivery = ConnPolicy::Delivery::thread;
  return p;
}

bool OutPortBase::depth_allowed(const ConnPolicy& asked) {
  if (asked.depth <= ConnPolicy::kMaxDepth) return true;
  refuse(full_name() + ": depth " + std::to_string(asked.depth) + " is above " + std::to_string(ConnPolicy::kMaxDepth) +
         " (ConnPolicy::kMaxDepth)");
  return false;
}

bool OutPortBase::reader_matches(Subscription& sub, const InPortBase* local) {
  const ReaderPolicy& wanted = sub.policy.reader;
  ReaderPolicy kept;  // any: untold, or a text this build cannot read (satisfies nothing asked)
  if (local != nullptr) {
    kept = local->reader();
    sub.reader = to_string(kept);
  } else if (!CORBA::is_nil(sub.port_ex)) {
    try {
      CORBA::String_var told = sub.port_ex->reader_policy();
      sub.reader = told.in();
      kept = parse_reader_policy(sub.reader);
    } catch (const std::invalid_argument&) {
    } catch (const CORBA::Exception& e) {
      // An InPortEx of an older build: it keeps something, but does not tell what.
      if (wanted.kind == ReaderPolicy::Kind::any) return true;
      refuse(full_name() + " -> " + sub.peer + ": the InPort does not tell what it keeps (" + e._name() +
             "), and the connection asks reader=" + to_string(wanted));
      return false;
    }
  }
  if (wanted.kind == ReaderPolicy::Kind::any) return true;
  if (sub.reader.empty()) {
    refuse(full_name() + " -> " + sub.peer + ": a 2004 InPort does not tell what it keeps, and the connection asks reader=" +
           to_string(wanted));
    return false;
  }
  if (kept.kind == ReaderPolicy::Kind::any || !satisfies(kept, wanted)) {
    refuse(full_name() + " -> " + sub.peer + ": the InPort keeps " + sub.reader + ", the connection asks reader=" +
           to_string(wanted));
    return false;
  }
  return true;
}

std::uint64_t OutPortBase::random_sender() {
  std::random_device random;
  return (std::uint64_t{random()} << 32) ^ random();
}

void OutPortBase::refuse(const std::string& why) {
  refused_.fetch_add(1, std::memory_order_relaxed);
  log().warn("subscribe refused: {}", why);
  std::lock_guard lock(mu_);
  last_refusal_ = why;
}

std::string OutPortBase::peer_name(RTM::InPort_ptr port, std::uint32_t call_timeout_ms) {
  CORBA::String_var name = port->name();
  RTM::InPortEx_var ex = RTM::InPortEx::_narrow(port);
  if (CORBA::is_nil(ex)) return std::string(name.in());
  omniORB::setClientCallTimeout(ex.in(), call_timeout_ms);
  CORBA::String_var owner = ex->owner();
  return std::string(owner.in()) + "." + name.in();
}

CORBA::Boolean OutPortBase::unsubscribe(RTM::ReqType r_type, RTM::InPort_ptr i_port) {
  if (CORBA::is_nil(i_port)) return false;
  PortableServer::Servant_var<InPortBase> local = InPortBase::find_local(i_port);
  return remove_matching([&](const Subscription& s) {
    if (s.once() != (r_type == RTM::once)) return false;
    if (!CORBA::is_nil(s.port)) return static_cast<bool>(s.port->_is_equivalent(i_port));
    return local.in() != nullptr && s.local.in() == local.in();
  });
}

char* OutPortBase::name() { return CORBA::string_dup(name_.c_str()); }
CORBA::TypeCode_ptr OutPortBase::port_type() { return CORBA::TypeCode::_duplicate(type_code()); }
char* OutPortBase::owner() { return CORBA::string_dup(owner_.c_str()); }

void OutPortBase::set_info(PortInfo info) {
  check_port_info(full_name(), element_count(), info);
  info_ = std::move(info);
}

RTM::PortDescription* OutPortBase::describe() { return to_idl(info_); }

RTM::PortCounters OutPortBase::counters() {
  const OutPortCounters c = counters_snapshot();
  RTM::PortCounters out{};
  out.accepted = c.written;
  out.rejected = c.refused;
  out.dropped = c.dropped;
  out.pushed = c.pushed;
  out.failed = c.failed;
  return out;
}

RTM::SubscriptionInfoList* OutPortBase::subscriptions() {
  reap_retired();
  auto* list = new RTM::SubscriptionInfoList;
  std::lock_guard lock(mu_);
  list->length(static_cast<CORBA::ULong>(subs_.size()));
  for (CORBA::ULong i = 0; i < subs_.size(); ++i) {
    const Subscription& s = *subs_[i];
    RTM::SubscriptionInfo& info = (*list)[i];
    info.req_type = s.once() ? RTM::once : RTM::repeated;
    info.subscriber = RTM::InPort::_duplicate(s.port.in());
    info.peer = CORBA::string_dup(s.peer.c_str());
    info.in_process = s.kind == ConnKind::in_process;
    info.path = CORBA::string_dup(info.in_process                            ? "in-process"
                                  : s.kind == ConnKind::shared_memory ? "shared memory"
                                                                      : "CORBA");
    info.kind = CORBA::string_dup(to_string(s.kind));
    info.asked = to_idl(s.asked);
    info.policy = to_idl(s.policy);
    info.reader = CORBA::string_dup(s.reader.c_str());
    info.pushed = s.pushed.load(std::memory_order_relaxed);
    info.dropped = s.dropped.load(std::memory_order_relaxed);
    info.failures = s.failures.load(std::memory_order_relaxed);
    const char* failure = s.failure_name.load(std::memory_order_relaxed);
    const std::uint32_t refused = s.refused_minor.load(std::memory_order_relaxed);
    const std::string why = !failure ? "" : refused ? std::string(failure) + ": " + access_refusal_text(refused) : failure;
    info.last_failure = CORBA::string_dup(why.c_str());
  }
  return list;
}

char* OutPortBase::last_error() { return CORBA::string_dup(last_refusal().c_str()); }

}  // namespace rtm
