// SPDX-License-Identifier: Apache-2.0
// Template definitions of rtm/connection.h; include that header, not this one.
#pragma once

#include <omniORB4/omniORB.h>

namespace rtm {

template <class Call>
bool Connection::guarded_call(Call call, bool* dead) {
  *dead = false;
  try {
    call();
    count_pushed();
    return true;
  } catch (const CORBA::OBJECT_NOT_EXIST& e) {
    *dead = count_failure(e._name(), true);
  } catch (const CORBA::COMM_FAILURE& e) {
    *dead = count_failure(e._name(), true);
  } catch (const CORBA::TRANSIENT& e) {
    *dead = count_failure(e._name(), true);
  } catch (const CORBA::TIMEOUT& e) {
    host_.timed_out.fetch_add(1, std::memory_order_relaxed);
    *dead = count_failure(e._name(), false);
  } catch (const CORBA::NO_PERMISSION& e) {
    *dead = count_failure(e._name(), false, e.minor());
  } catch (const CORBA::Exception& e) {
    *dead = count_failure(e._name(), false);
  } catch (const std::exception& e) {
    *dead = count_failure("a C++ exception", false);
  }
  return false;
}

// ---- DirectConnection ----

template <PortData T>
typename TypedConnection<T>::Push DirectConnection<T>::push(const T& value, bool) {
  if (this->who_.check_active && !this->who_.local->active()) {
    // The InPort was deactivated: the same as OBJECT_NOT_EXIST from a remote one.
    return {this->count_failure("OBJECT_NOT_EXIST", true), 0};
  }
  static_cast<InPort<T>*>(this->who_.local.in())->deliver(value);
  this->count_pushed();
  return {this->once(), 0};
}

// ---- RingConnection ----

template <PortData T>
typename TypedConnection<T>::Push RingConnection<T>::push(const T&, bool) {
  // write() put the datum in the ring already; the reader counts what it skips. Only write()
  // changes these, under the port's lock: stores, not locked adds.
  const auto bump = [](std::atomic<std::uint64_t>& n) {
    n.store(n.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  };
  bump(this->pushed_);
  bump(this->host_.ring_pushed);
  return {};
}

template <PortData T>
void RingConnection<T>::run() {
  std::unique_lock lock(this->slot_mu_);
  for (;;) {
    if (this->slot_cv_.wait_for(lock, std::chrono::seconds(1), [&] { return this->stop_; })) return;
    lock.unlock();
    bool gone = false;
    const char* failure = nullptr;
    try {
      gone = this->who_.port->_non_existent();
      if (gone) failure = "OBJECT_NOT_EXIST";
    } catch (const CORBA::TIMEOUT& e) {
      failure = e._name();  // busy, not gone: counted, never dropped for it
    } catch (const CORBA::Exception& e) {
      gone = true;
      failure = e._name();
    }
    bool drop = false;
    if (failure) {
      drop = this->count_failure(failure, gone);
    } else {
      this->failures_.store(0, std::memory_order_relaxed);
      this->failure_name_.store(nullptr, std::memory_order_relaxed);
    }
    lock.lock();
    if (drop) {
      lock.unlock();
      this->leave();
      return;
    }
  }
}

template <PortData T>
void RingConnection<T>::stopped() {
  detach_quietly(reader_.in(), segment_);
}

// ---- QueuedConnection ----

template <PortData T>
QueuedConnection<T>::QueuedConnection(ConnectionHost& host, ConnKind kind, Subscriber who)
    : TypedConnection<T>(host, kind, std::move(who)) {
  ring_.resize(std::max<std::uint32_t>(this->who_.policy.depth, 1));
}

template <PortData T>
typename TypedConnection<T>::Push QueuedConnection<T>::push(const T& value, bool may_call) {
  std::uint64_t call_seq = 0;
  {
    std::lock_guard slot_lock(this->slot_mu_);
    // A once-connection takes one datum at a time until one is delivered: the first written
    // after it was made, or the next when that one's delivery failed.
    if (this->once() && (this->done_ || in_flight_ || written_seq_ != delivered_seq_)) return {};
    call_seq = take_call_locked(may_call);
    if (call_seq == 0) {
      ring_[written_seq_ % ring_.size()] = value;
      ++written_seq_;
    }
  }
  if (call_seq != 0) return {false, call_seq};
  this->slot_cv_.notify_one();
  return {};
}

template <PortData T>
void QueuedConnection<T>::run() {
  std::unique_lock lock(this->slot_mu_);
  for (;;) {
    // Not while write() makes a call for this connection: data leave in order.
    this->slot_cv_.wait(lock, [&] { return this->stop_ || (written_seq_ != delivered_seq_ && !in_flight_); });
    if (this->stop_) return;
    // Oldest first; what the ring no longer holds was overwritten: count it as dropped.
    const std::uint64_t behind = written_seq_ - delivered_seq_;
    if (behind > ring_.size()) {
      const std::uint64_t missed = behind - ring_.size();
      this->dropped_.fetch_add(missed, std::memory_order_relaxed);
      this->host_.dropped.fetch_add(missed, std::memory_order_relaxed);
      delivered_seq_ += missed;
    }
    const std::uint64_t seq = ++delivered_seq_;
    in_flight_ = true;
    sending_ = ring_[(seq - 1) % ring_.size()];
    bool drop = false;
    lock.unlock();
    const bool ok = this->guarded_call([&] { deliver(sending_, seq); }, &drop);
    lock.lock();
    in_flight_ = false;
    if (ok) {
      delivered();
      drop = this->once();
    }
    if (drop) {
      lock.unlock();  // lock order: the port's before slot_mu_
      this->leave();
      return;
    }
  }
}

template <PortData T>
void QueuedConnection<T>::deliver(const T& value, std::uint64_t) {
  if (this->who_.check_active && !this->who_.local->active()) throw CORBA::OBJECT_NOT_EXIST(0, CORBA::COMPLETED_NO);
  static_cast<InPort<T>*>(this->who_.local.in())->deliver(value);
}

// ---- RemoteConnection ----

template <PortData T>
RemoteConnection<T>::RemoteConnection(ConnectionHost& host, Subscriber who, bool by_writer)
    : QueuedConnection<T>(host, ConnKind::remote_by_thread, std::move(who)) {
  if (!CORBA::is_nil(this->who_.port_ordered)) sender_ = random_sender();
  if (by_writer && !this->once()) {
    writer_ = make_writer_references(this->who_, host.writer_call_timeout_ms, host.oneway);
    if (!CORBA::is_nil(writer_.port)) this->kind_ = ConnKind::remote_by_writer;
  }
}

template <PortData T>
std::uint64_t RemoteConnection<T>::take_call_locked(bool may_call) {
  const bool idle = !this->in_flight_ && this->written_seq_ == this->delivered_seq_;
  if (!may_call || !idle || !writer_may_call_ || CORBA::is_nil(writer_.port)) return 0;
  this->in_flight_ = true;
  writer_calling_ = true;
  ++this->delivered_seq_;
  return ++this->written_seq_;
}

template <PortData T>
void RemoteConnection<T>::writer_call(const T& value, std::uint64_t seq, bool within_budget) {
  if (!within_budget) {
    std::lock_guard slot_lock(this->slot_mu_);
    this->ring_[(this->written_seq_ - 1) % this->ring_.size()] = value;
    --this->delivered_seq_;
    this->in_flight_ = false;
    writer_calling_ = false;
    this->slot_cv_.notify_all();  // under the lock: once it is released, this may be freed
    return;
  }
  bool dead = false;
  const bool delivered = this->guarded_call([&] { call(value, true, seq); }, &dead);
  if (delivered) this->host_.by_writer.fetch_add(1, std::memory_order_relaxed);
  finish_writer_call(delivered, dead);
}

template <PortData T>
void RemoteConnection<T>::finish_writer_call(bool delivered, bool dead) {
  if (dead || (delivered && this->once())) this->leave();  // still calling: stays until the flag below is cleared
  std::lock_guard slot_lock(this->slot_mu_);
  this->in_flight_ = false;
  writer_calling_ = false;
  // After a failure the thread takes the next data (a slow subscriber then costs write() no
  // more), until it has delivered again.
  if (!delivered) writer_may_call_ = false;
  // Wake only whom this call held up: the delivery thread when data were queued meanwhile, a
  // stop_and_join() (stop_ set) waiting for the call to end. A wake-up nobody needs is a
  // context switch per datum (on a shared CPU, the price of a round trip). Notified before the
  // lock is released: once it is, a stop_and_join() may free this.
  if (this->stop_ || this->written_seq_ != this->delivered_seq_) this->slot_cv_.notify_all();
}

template <PortData T>
void RemoteConnection<T>::wait_for_writer(std::unique_lock<std::mutex>& slot_lock) {
  this->slot_cv_.wait(slot_lock, [&] { return !writer_calling_; });
}

template <PortData T>
void RemoteConnection<T>::call(const T& value, bool by_writer, std::uint64_t seq) {
  CORBA::Any any;
  DataTraits<T>::insert(any, value);
  RTM::InPortOrdered_ptr ordered = by_writer ? writer_.port_ordered.in() : this->who_.port_ordered.in();
  if (!CORBA::is_nil(ordered)) {
    if (this->host_.oneway) ordered->push_in_order(any, sender_, seq);
    else ordered->put_in_order(any, sender_, seq);
    return;
  }
  RTM::InPortEx_ptr ex = by_writer ? writer_.port_ex.in() : this->who_.port_ex.in();
  if (this->host_.oneway && !CORBA::is_nil(ex)) ex->push(any);
  else (by_writer ? writer_.port.in() : this->who_.port.in())->put(any);
}

}  // namespace rtm
