// SPDX-License-Identifier: Apache-2.0
#include "browser/watch_port.h"

#include "browser/browser.h"
#include "rtm/data.h"

#include <fmt/format.h>

#include <algorithm>

namespace rtm::cli {

WatchPort::WatchPort(std::string owner, CORBA::TypeCode_ptr type, std::size_t capacity)
    : owner_(std::move(owner)), type_(CORBA::TypeCode::_duplicate(type)), capacity_(capacity),
      ring_type_(rtm::find_ring_data_type(type)) {
  if (ring_type_ != nullptr) datum_.resize(ring_type_->size);
}

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
  queue_locked(value);
  arrived_.notify_one();
}

void WatchPort::queue_locked(CORBA::Any value) {
  ++received_;
  if (queue_.size() >= capacity_) {
    queue_.pop_front();
    ++overflowed_;
  }
  queue_.push_back(std::move(value));
}

CORBA::Boolean WatchPort::attach_ring(const char* segment, const char* host, CORBA::ULongLong type_id,
                                      CORBA::Long /*writer_pid*/, CORBA::ULongLong /*writer_start*/,
                                      CORBA::String_out why) {
  auto refuse = [&](const std::string& reason) {
    why = CORBA::string_dup(reason.c_str());
    return false;
  };
  if (std::string(host) != rtm::shm_host_identity()) return refuse("the publisher runs on another host or network namespace");
  if (ring_type_ == nullptr) return refuse(rtm::type_name(type_) + " has no plain layout this tool knows");
  if (type_id != ring_type_->type_id) return refuse("the ring carries another data type");
  std::lock_guard lock(mutex_);
  for (const auto& r : rings_) {
    if (r->name != segment) continue;
    ++r->attached;
    why = CORBA::string_dup("");
    return true;
  }
  if (rings_.size() >= kMaxRings) return refuse(fmt::format("already {} rings, the most a watch reads", kMaxRings));
  try {
    rtm::ShmSegment mapped = rtm::ShmSegment::open(segment);
    rtm::ShmRingReader reader(mapped.data(), mapped.size(), type_id);
    rings_.push_back(std::unique_ptr<Ring>(new Ring{segment, std::move(mapped), reader}));
  } catch (const std::exception& e) {
    return refuse(e.what());
  }
  why = CORBA::string_dup("");
  return true;
}

CORBA::Boolean WatchPort::detach_ring(const char* segment) {
  std::lock_guard lock(mutex_);
  for (auto it = rings_.begin(); it != rings_.end(); ++it) {
    if ((*it)->name != segment) continue;
    if (--(*it)->attached > 0) return true;
    take_from_rings_locked();  // what was written before the unsubscribe is shown
    rings_.erase(it);
    return true;
  }
  return false;
}

// Every datum the rings hold that this port has not taken, in the order written; those the
// publisher overwrote first are counted as dropped by the display (it fell a ring behind).
void WatchPort::take_from_rings_locked() {
  for (const auto& ring : rings_) {
    for (;;) {
      const rtm::RingRead r = ring->reader.take_next(datum_);
      if (r.status != rtm::ReadStatus::new_data) break;
      overflowed_ += r.missed;
      if (r.size != datum_.size()) continue;  // the reader checked the layout: cannot happen
      CORBA::Any value;
      ring_type_->to_any(datum_, value);
      ++shared_memory_;
      queue_locked(std::move(value));
    }
  }
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

char* WatchPort::reader_policy() { return CORBA::string_dup(("fifo:" + std::to_string(capacity_)).c_str()); }

char* WatchPort::last_error() {
  std::lock_guard lock(mutex_);
  return CORBA::string_dup(last_error_.c_str());
}

bool WatchPort::drain(std::vector<CORBA::Any>& out, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  std::unique_lock lock(mutex_);
  for (;;) {
    take_from_rings_locked();
    if (!queue_.empty()) break;
    const auto now = std::chrono::steady_clock::now();
    if (now >= deadline) return false;
    // A put wakes this at once; a ring is looked at again after kRingPollMs.
    const auto until = rings_.empty() ? deadline : std::min(deadline, now + kRingPollMs);
    arrived_.wait_until(lock, until, [this] { return !queue_.empty(); });
  }
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
std::uint64_t WatchPort::shared_memory() const {
  std::lock_guard lock(mutex_);
  return shared_memory_;
}
bool WatchPort::reads_ring() const {
  std::lock_guard lock(mutex_);
  return !rings_.empty();
}
std::uint64_t WatchPort::rejected() const {
  std::lock_guard lock(mutex_);
  return rejected_;
}

// ============================ WatchSubscription =======================

WatchSubscription::WatchSubscription(rtm::Orb& orb, CORBA::Object_ptr out, CORBA::TypeCode_ptr type,
                                     const std::string& address, std::string owner, std::size_t capacity,
                                     const std::string& what)
    : orb_(orb), out_(RTM::OutPort::_narrow(out)), servant_(new WatchPort(std::move(owner), type, capacity)),
      keep_(servant_) {
  CORBA::Object_var ref = orb_.activate(servant_);
  in_ = RTM::InPort::_narrow(ref);
  bool subscribed = false;
  try {
    subscribed = out_->subscribe(RTM::repeated, in_);
  } catch (...) {
    orb_.deactivate(servant_);
    throw;
  }
  if (!subscribed) {
    orb_.deactivate(servant_);
    throw BrowseError(fmt::format("{} refused {}", address, what));
  }
  out_ex_ = RTM::OutPortEx::_narrow(out_);
}

WatchSubscription::~WatchSubscription() { finish(); }

std::optional<unsigned long long> WatchSubscription::publisher_dropped() const {
  if (CORBA::is_nil(out_ex_)) return std::nullopt;
  try {
    RTM::SubscriptionInfoList_var subs = out_ex_->subscriptions();
    for (CORBA::ULong i = 0; i < subs->length(); ++i)
      if (subs[i].subscriber->_is_equivalent(in_)) return subs[i].dropped;
  } catch (const CORBA::Exception&) {
  }
  return std::nullopt;
}

std::string WatchSubscription::finish() {
  if (finished_) return "";
  finished_ = true;
  std::string failed;
  try {
    out_->unsubscribe(RTM::repeated, in_);
  } catch (const CORBA::Exception& e) {
    failed = e._name();
  }
  orb_.deactivate(servant_);
  return failed;
}

}  // namespace rtm::cli
