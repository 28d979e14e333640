// SPDX-License-Identifier: Apache-2.0
// Template definitions of rtm/inport.h; include that header, not this one.
#pragma once

#include "rtm/cycle_tap.h"

#include <algorithm>
#include <span>
#include <stdexcept>

namespace rtm {

template <PortData T>
InPort<T>::InPort(std::string name, std::string owner, InPortPolicy policy)
    : InPortBase(std::move(name), std::move(owner), std::move(policy)) {
  ring_.resize(policy_.kind() == InPortPolicy::Kind::Fifo ? policy_.capacity() : 1);
  if (policy_.kind() == InPortPolicy::Kind::Callback) {
    callback_ = policy_.callback_for<T>();
    if (!callback_)
      throw std::invalid_argument("InPort " + full_name() + " carries " + std::string(DataTraits<T>::name) +
                                  " but its callback policy takes another type (" +
                                  policy_.callback_type()->name() + ")");
  }
}

template <PortData T>
bool InPort<T>::keep(const T& value, std::unique_lock<std::mutex>& lock) {
  if (policy_.kind() != InPortPolicy::Kind::Fifo) {
    if (unread_) dropped_.fetch_add(1, std::memory_order_relaxed);
    ring_[0] = value;
    unread_ = true;
    count_ = 1;
    return true;
  }
  const std::size_t capacity = ring_.size();
  if (count_ == capacity) {
    switch (policy_.full_policy()) {
      case FullPolicy::DropOldest:
        head_ = (head_ + 1) % capacity;
        --count_;
        dropped_.fetch_add(1, std::memory_order_relaxed);
        break;
      case FullPolicy::DropNewest:
        dropped_.fetch_add(1, std::memory_order_relaxed);
        return false;
      case FullPolicy::Block:
        if (!space_cv_.wait_for(lock, std::chrono::nanoseconds(policy_.block_timeout_ns()),
                                [&] { return count_ < capacity; })) {
          dropped_.fetch_add(1, std::memory_order_relaxed);
          return false;
        }
        break;
    }
  }
  ring_[(head_ + count_) % capacity] = value;
  ++count_;
  return true;
}

template <PortData T>
bool InPort<T>::store(const T& value, bool in_process, const SenderSeq* order) {
  std::unique_lock lock(mu_);
  if (order != nullptr && !order_.admit(order->sender, order->seq)) {
    late_.fetch_add(1, std::memory_order_relaxed);
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  take_from_rings_locked();  // data already in a ring were written before this one
  if (!keep(value, lock)) return false;
  accepted_.fetch_add(1, std::memory_order_relaxed);
  if (in_process) in_process_.fetch_add(1, std::memory_order_relaxed);
  notify_arrival();
  lock.unlock();
  if (callback_) {
    try {
      (*callback_)(value);
    } catch (const std::exception& e) {
      callback_failed(e.what());
    } catch (...) {
      callback_failed("unknown exception");
    }
  }
  return true;
}

template <PortData T>
std::size_t InPort<T>::store_from_ring(AttachedRing& ring) {
  std::size_t taken = 0;
  if constexpr (std::is_trivially_copyable_v<T>) {
    T datum;
    const auto bytes = std::as_writable_bytes(std::span(&datum, 1));
    for (;; ++taken) {
      const RingRead r = ring.reader.take_next(bytes);
      if (r.status != ReadStatus::new_data || r.size != sizeof(T)) break;
      if (r.missed > 0) dropped_.fetch_add(r.missed, std::memory_order_relaxed);
      ring.last_number = r.number;
      if (store(datum, false)) shared_memory_.fetch_add(1, std::memory_order_relaxed);
    }
  }
  return taken;
}

template <PortData T>
std::string InPort<T>::ring_refusal(CORBA::ULongLong type_id) const {
  if constexpr (!std::is_trivially_copyable_v<T>) {
    return std::string(DataTraits<T>::name) + " is not plain memory (a sequence or a string)";
  } else {
    if (type_id != ring_type_id<T>()) return "the ring carries another data type";
    return "";
  }
}

// Latest: the newest datum, and what it skipped counted as dropped. FIFO: each datum in order
// as a put would store it, and those the writer overwrote first counted as dropped.
template <PortData T>
void InPort<T>::take_from_ring_locked(AttachedRing& ring) {
  if constexpr (std::is_trivially_copyable_v<T>) {
    T datum;
    const auto bytes = std::as_writable_bytes(std::span(&datum, 1));
    // keep() waits only under FullPolicy::Block, whose rings a waiter reads (store_from_ring).
    std::unique_lock<std::mutex> unused;
    const bool fifo = policy_.kind() == InPortPolicy::Kind::Fifo;
    // Nothing new (the common case of a reader polling in its cycle): one load. A FIFO reader
    // still behind the head it saw last loads nothing the writer writes.
    if (fifo ? !ring.reader.has_new() : ring.reader.published() == ring.last_number) return;
    std::uint64_t kept = 0, skipped = 0;
    for (;;) {
      const RingRead r = fifo ? ring.reader.take_next(bytes) : ring.reader.take_latest(bytes);
      if (r.status != ReadStatus::new_data || r.size != sizeof(T)) break;
      skipped += fifo ? r.missed : r.number - ring.last_number - 1;
      ring.last_number = r.number;
      if (keep(datum, unused)) ++kept;
      // FIFO: on until take_next() finds nothing newer (it looks at the writer's head once
      // it has caught up with the head it saw, not per datum).
      if (!fifo) break;
    }
    // Counted once per take, not per datum: each is an atomic a reader of the counters shares.
    if (skipped > 0) dropped_.fetch_add(skipped, std::memory_order_relaxed);
    if (kept > 0) {
      accepted_.fetch_add(kept, std::memory_order_relaxed);
      shared_memory_.fetch_add(kept, std::memory_order_relaxed);
    }
  }
}

template <PortData T>
std::size_t InPort<T>::take_straight_locked(std::span<T> out) {
  std::size_t taken = 0;
  if constexpr (std::is_trivially_copyable_v<T>) {
    const std::uint64_t capacity = ring_.size();
    std::uint64_t skipped = 0;
    for (const auto& ring : rings_) {
      if (ring->has_waiter) continue;
      // has_new() and skip_older() load the writer's head only once this reader caught up
      // with the head it saw last: taking a backlog costs the writer no cache miss per datum.
      while (taken < out.size() && ring->reader.has_new()) {
        skipped += ring->reader.skip_older(capacity);
        const RingRead r = ring->reader.take_next(std::as_writable_bytes(out.subspan(taken, 1)));
        if (r.status != ReadStatus::new_data || r.size != sizeof(T)) break;
        skipped += r.missed;
        ring->last_number = r.number;
        ++taken;
      }
    }
    if (skipped > 0) dropped_.fetch_add(skipped, std::memory_order_relaxed);
    if (taken > 0) {
      accepted_.fetch_add(taken, std::memory_order_relaxed);
      shared_memory_.fetch_add(taken, std::memory_order_relaxed);
    }
  }
  return taken;
}

template <PortData T>
bool InPort<T>::has_unread_locked() {
  if (!reads_rings_straight()) take_from_rings_locked();
  if (policy_.kind() != InPortPolicy::Kind::Fifo) return unread_;  // set only with a datum stored
  if (count_ > 0) return true;
  for (const auto& ring : rings_)
    if (!ring->has_waiter && ring->reader.has_new()) return true;
  return false;
}

template <PortData T>
ReadResult InPort<T>::read(T& out) {
  ReadResult result;
  if (tap_ == nullptr) [[likely]] {
    result = read_port(out);
  } else if (tap_->replaying()) {
    result = tap_->replay_read(out);
  } else {
    result = read_port(out);
    tap_->logged_read(result, out);
  }
  if constexpr (Stamped<T>) {
    if (result == ReadResult::NewData) {
      last_stamp_ns_ = to_ns(out.tm);
      ++stamps_taken_;
      last_expired_ = false;
    }
  }
  return result;
}

template <PortData T>
std::size_t InPort<T>::read_many(std::span<T> out) {
  std::size_t n = 0;
  if (tap_ == nullptr) [[likely]] {
    n = read_many_port(out);
  } else if (tap_->replaying()) {
    n = tap_->replay_read_many(out);
  } else {
    n = read_many_port(out);
    tap_->logged_read_many(std::span<const T>(out.data(), n));  // a read of none too: the order of calls
  }
  if constexpr (Stamped<T>) {
    if (n > 0) {
      last_stamp_ns_ = to_ns(out[n - 1].tm);  // oldest first: the newest is the last
      stamps_taken_ += n;
      last_expired_ = false;
    }
  }
  return n;
}

template <PortData T>
std::unique_ptr<PortTap> InPort<T>::tap(TapSink* sink, std::uint16_t key, std::uint32_t capacity) {
  return make_tap(sink, key, capacity, tap_);
}

template <PortData T>
ReadResult InPort<T>::read_port(T& out) {
  std::unique_lock lock(mu_);
  // The same-host path: no system call. A FIFO takes what it holds first (older than what
  // the rings still hold: a put drains them before it stores), then the rings straight.
  const bool straight = reads_rings_straight();
  if (!straight) take_from_rings_locked();
  if (policy_.kind() != InPortPolicy::Kind::Fifo) {
    if (count_ == 0) return ReadResult::NoData;
    out = ring_[0];
    if (!unread_) return ReadResult::OldData;
    unread_ = false;
    return ReadResult::NewData;
  }
  if (count_ == 0 && straight && take_straight_locked(std::span(&out, 1)) == 1) {
    last_read_ = out;
    ever_read_ = true;
    return ReadResult::NewData;
  }
  if (count_ == 0) {
    if (!ever_read_) return ReadResult::NoData;
    out = last_read_;
    return ReadResult::OldData;
  }
  out = ring_[head_];
  last_read_ = ring_[head_];
  head_ = (head_ + 1) % ring_.size();
  --count_;
  ever_read_ = true;
  const bool wake_putter = policy_.full_policy() == FullPolicy::Block;
  lock.unlock();
  if (wake_putter) space_cv_.notify_one();
  return ReadResult::NewData;
}

template <PortData T>
std::size_t InPort<T>::read_many_port(std::span<T> out) {
  if (out.empty()) return 0;
  std::unique_lock lock(mu_);
  const bool straight = reads_rings_straight();  // as read()
  if (!straight) take_from_rings_locked();
  if (policy_.kind() != InPortPolicy::Kind::Fifo) {
    if (count_ == 0 || !unread_) return 0;
    out[0] = ring_[0];
    unread_ = false;
    return 1;
  }
  std::size_t n = std::min(count_, out.size());
  for (std::size_t i = 0; i < n; ++i) {
    out[i] = ring_[head_];
    head_ = (head_ + 1) % ring_.size();
  }
  count_ -= n;
  if (count_ == 0 && straight) n += take_straight_locked(out.subspan(n));
  if (n == 0) return 0;
  last_read_ = out[n - 1];
  ever_read_ = true;
  const bool wake_putter = policy_.full_policy() == FullPolicy::Block;
  lock.unlock();
  if (wake_putter) space_cv_.notify_all();
  return n;
}

template <PortData T>
void InPort<T>::deliver(const T& value) {
  store(value, true);
}

template <PortData T>
std::size_t InPort<T>::queued() const {
  std::lock_guard lock(mu_);
  take_from_rings_locked();  // what the rings hold counts as queued
  if (policy_.kind() == InPortPolicy::Kind::Fifo) return count_;
  return unread_ ? 1 : 0;
}

template <PortData T>
const T& InPort<T>::extract(const CORBA::Any& value) {
  CORBA::TypeCode_var got = value.type();
  const T* datum = nullptr;
  if (!got->equivalent(type_code()) || !DataTraits<T>::extract(value, datum) || datum == nullptr) {
    reject(got.in());
    throw CORBA::BAD_PARAM(kMinorWrongDataType, CORBA::COMPLETED_NO);
  }
  return *datum;  // owned by value
}

template <PortData T>
void InPort<T>::put(const CORBA::Any& value) {
  store(extract(value), false);
}

template <PortData T>
void InPort<T>::put_in_order(const CORBA::Any& value, CORBA::ULongLong sender, CORBA::ULongLong seq) {
  const SenderSeq order{sender, seq};
  store(extract(value), false, &order);
}

}  // namespace rtm
