// SPDX-License-Identifier: Apache-2.0
// Template definitions of rtm/inport.h; include that header, not this one.
#pragma once

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
void InPort<T>::store(const T& value, bool in_process, const SenderSeq* order) {
  std::unique_lock lock(mu_);
  if (order != nullptr && !order_.admit(order->sender, order->seq)) {
    late_.fetch_add(1, std::memory_order_relaxed);
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  if (policy_.kind() == InPortPolicy::Kind::Fifo) {
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
          return;
        case FullPolicy::Block:
          if (!space_cv_.wait_for(lock, std::chrono::nanoseconds(policy_.block_timeout_ns()),
                                  [&] { return count_ < capacity; })) {
            dropped_.fetch_add(1, std::memory_order_relaxed);
            return;
          }
          break;
      }
    }
    ring_[(head_ + count_) % capacity] = value;
    ++count_;
  } else {
    if (unread_) dropped_.fetch_add(1, std::memory_order_relaxed);
    ring_[0] = value;
    unread_ = true;
    count_ = 1;
  }
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
}

template <PortData T>
ReadResult InPort<T>::read(T& out) {
  std::unique_lock lock(mu_);
  if (policy_.kind() != InPortPolicy::Kind::Fifo) {
    if (count_ == 0) return ReadResult::NoData;
    out = ring_[0];
    if (!unread_) return ReadResult::OldData;
    unread_ = false;
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
void InPort<T>::deliver(const T& value) {
  store(value, true);
}

template <PortData T>
std::size_t InPort<T>::queued() const {
  std::lock_guard lock(mu_);
  if (policy_.kind() == InPortPolicy::Kind::Fifo) return count_;
  return unread_ ? 1 : 0;
}

template <PortData T>
const T& InPort<T>::extract(const CORBA::Any& value) {
  CORBA::TypeCode_var got = value.type();
  const T* datum = nullptr;
  if (!got->equivalent(type_code()) || !(value >>= datum) || datum == nullptr) {
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
