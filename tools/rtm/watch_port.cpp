// SPDX-License-Identifier: Apache-2.0
#include "watch_port.h"

#include "rtm/data.h"

#include <fmt/format.h>

namespace rtm::cli {

WatchPort::WatchPort(std::string owner, CORBA::TypeCode_ptr type, std::size_t capacity)
    : owner_(std::move(owner)), type_(CORBA::TypeCode::_duplicate(type)), capacity_(capacity) {}

void WatchPort::put(const CORBA::Any& value) { take(value, nullptr); }

void WatchPort::put_in_order(const CORBA::Any& value, CORBA::ULongLong sender, CORBA::ULongLong seq) {
  const rtm::SenderSeq order{sender, seq};
  take(value, &order);
}

void WatchPort::push_in_order(const CORBA::Any& value, CORBA::ULongLong sender, CORBA::ULongLong seq) {
  try {
    put_in_order(value, sender, seq);
  } catch (const CORBA::BAD_PARAM&) {
    // oneway: as push()
  }
}

void WatchPort::take(const CORBA::Any& value, const rtm::SenderSeq* order) {
  CORBA::TypeCode_var got = value.type();
  std::lock_guard lock(mutex_);
  if (!got->equivalent(type_)) {
    ++rejected_;
    last_error_ = fmt::format("{}.in ({}) got {}", owner_, rtm::type_name(type_), rtm::type_name(got));
    throw CORBA::BAD_PARAM(rtm::kMinorWrongDataType, CORBA::COMPLETED_NO);
  }
  if (order != nullptr && !order_.admit(order->sender, order->seq)) {
    ++late_;  // arrived after a later datum of its sender: shown out of order, so not at all
    return;
  }
  ++received_;
  if (queue_.size() >= capacity_) {
    queue_.pop_front();
    ++overflowed_;
  }
  queue_.push_back(value);
  arrived_.notify_one();
}

void WatchPort::push(const CORBA::Any& value) {
  try {
    put(value);
  } catch (const CORBA::BAD_PARAM&) {
    // oneway: nobody to tell; counted and kept in last_error
  }
}

char* WatchPort::name() { return CORBA::string_dup("in"); }
CORBA::TypeCode_ptr WatchPort::port_type() { return CORBA::TypeCode::_duplicate(type_); }
char* WatchPort::owner() { return CORBA::string_dup(owner_.c_str()); }

RTM::PortCounters WatchPort::counters() {
  std::lock_guard lock(mutex_);
  RTM::PortCounters c{};
  c.accepted = received_;
  c.rejected = rejected_;
  c.dropped = overflowed_ + late_;
  return c;
}

RTM::PortDescription* WatchPort::describe() {
  auto* out = new RTM::PortDescription;
  out->description = "rtm watch display";
  return out;
}

char* WatchPort::last_error() {
  std::lock_guard lock(mutex_);
  return CORBA::string_dup(last_error_.c_str());
}

bool WatchPort::drain(std::vector<CORBA::Any>& out, std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  if (!arrived_.wait_for(lock, timeout, [this] { return !queue_.empty(); })) return false;
  while (!queue_.empty()) {
    out.push_back(std::move(queue_.front()));
    queue_.pop_front();
  }
  return true;
}

std::uint64_t WatchPort::received() const {
  std::lock_guard lock(mutex_);
  return received_;
}
std::uint64_t WatchPort::overflowed() const {
  std::lock_guard lock(mutex_);
  return overflowed_;
}
std::uint64_t WatchPort::late() const {
  std::lock_guard lock(mutex_);
  return late_;
}
std::uint64_t WatchPort::rejected() const {
  std::lock_guard lock(mutex_);
  return rejected_;
}

}  // namespace rtm::cli
