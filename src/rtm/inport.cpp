// SPDX-License-Identifier: Apache-2.0
#include "rtm/inport.h"

#include "rt/clock.h"
#include "rt/thread.h"

#include "rtm/log.h"
#include "rtm/orb.h"

#include <pthread.h>

#include <algorithm>
#include <stdexcept>

namespace rtm {

InPortPolicy InPortPolicy::fifo(std::size_t capacity, FullPolicy full, std::int64_t block_timeout_ns) {
  if (capacity == 0) throw std::invalid_argument("InPortPolicy::fifo: capacity must be >= 1");
  if (full == FullPolicy::Block && block_timeout_ns <= 0)
    throw std::invalid_argument("InPortPolicy::fifo: block_timeout_ns must be > 0 for FullPolicy::Block");
  InPortPolicy p(Kind::Fifo);
  p.capacity_ = capacity;
  p.full_ = full;
  p.block_timeout_ns_ = block_timeout_ns;
  return p;
}

// ---------------------------------------------------------------------------------------------
// The InPorts of this process, so that an OutPort can tell a reference to one of them from a
// reference into another process.
namespace {
struct LocalEntry {
  InPortBase* port;
  CORBA::Object_var ref;
};
std::mutex& registry_mu() {
  static std::mutex mu;
  return mu;
}
std::vector<LocalEntry>& registry() {
  static std::vector<LocalEntry> entries;
  return entries;
}
}  // namespace

PortableServer::Servant_var<InPortBase> InPortBase::find_local(CORBA::Object_ptr ref) {
  PortableServer::Servant_var<InPortBase> found;
  if (CORBA::is_nil(ref)) return found;
  std::lock_guard lock(registry_mu());
  for (auto& entry : registry()) {
    // _is_equivalent compares object keys and addresses locally: a reference from another
    // process has another endpoint, so it never matches.
    if (entry.ref->_is_equivalent(ref)) {
      entry.port->_add_ref();
      found = entry.port;
      break;
    }
  }
  return found;
}

InPortBase::InPortBase(std::string name, std::string owner, InPortPolicy policy)
    : name_(std::move(name)), owner_(std::move(owner)), policy_(std::move(policy)) {
  if (name_.empty()) throw std::invalid_argument("InPort: empty port name (owner '" + owner_ + "')");
}

InPortBase::~InPortBase() {
  // Normally deactivate() already unregistered the port; the POA may run this destructor
  // while holding its own locks, so the registry lock is only taken when really needed.
  if (!active_.load()) return;
  std::lock_guard lock(registry_mu());
  auto& entries = registry();
  entries.erase(std::remove_if(entries.begin(), entries.end(), [this](const LocalEntry& e) { return e.port == this; }),
                entries.end());
}

std::string InPortBase::full_name() const { return owner_ + "." + name_; }

InPortCounters InPortBase::counters_snapshot() const {
  {
    // Data waiting in a publisher's ring have arrived as much as a put's: they count now, not
    // only once the component reads (they stay unread for it).
    std::lock_guard lock(mu_);
    take_from_rings_locked();
  }
  InPortCounters c;
  c.accepted = accepted_.load(std::memory_order_relaxed);
  c.rejected = rejected_.load(std::memory_order_relaxed);
  c.dropped = dropped_.load(std::memory_order_relaxed);
  c.in_process = in_process_.load(std::memory_order_relaxed);
  c.callback_failures = callback_failures_.load(std::memory_order_relaxed);
  c.late = late_.load(std::memory_order_relaxed);
  c.shared_memory = shared_memory_.load(std::memory_order_relaxed);
  return c;
}

std::string InPortBase::last_error_text() const {
  std::lock_guard lock(mu_);
  return last_error_;
}

void InPortBase::set_arrival_signal(std::shared_ptr<ArrivalSignal> signal) {
  std::lock_guard lock(mu_);
  signal_ = std::move(signal);
  // Rings read until now in read() must from now on wake the activity as they arrive.
  if (signal_)
    for (auto& ring : rings_)
      if (!ring->has_waiter) start_waiter_locked(*ring);
}

ReaderPolicy InPortBase::reader() const {
  ReaderPolicy r;
  switch (policy_.kind()) {
    case InPortPolicy::Kind::Latest: r.kind = ReaderPolicy::Kind::latest; break;
    case InPortPolicy::Kind::Fifo:
      r.kind = ReaderPolicy::Kind::fifo;
      r.capacity = static_cast<std::uint32_t>(policy_.capacity());
      break;
    case InPortPolicy::Kind::Callback: r.kind = ReaderPolicy::Kind::callback; break;
  }
  return r;
}

char* InPortBase::reader_policy() { return CORBA::string_dup(to_string(reader()).c_str()); }

bool InPortBase::stores_without_waiting() const {
  switch (policy_.kind()) {
    case InPortPolicy::Kind::Latest: return true;
    case InPortPolicy::Kind::Fifo: return policy_.full_policy() != FullPolicy::Block;
    case InPortPolicy::Kind::Callback: return false;
  }
  return false;
}

// ---------------------------------------------------------------------------------------------
// The same-host path

CORBA::Boolean InPortBase::attach_ring(const char* segment, const char* host, CORBA::ULongLong type_id,
                                       CORBA::Long writer_pid, CORBA::ULongLong writer_start, CORBA::String_out why) {
  auto refuse = [&](const std::string& reason) {
    why = CORBA::string_dup(reason.c_str());
    return false;
  };
  if (std::string(host) != shm_host_identity()) return refuse("the publisher runs on another host or network namespace");
  if (std::string type_why = ring_refusal(type_id); !type_why.empty()) return refuse(type_why);
  std::shared_ptr<AttachedRing> ring;
  try {
    ShmSegment mapped = ShmSegment::open(segment);
    ShmRingReader reader(mapped.data(), mapped.size(), type_id);
    ring.reset(new AttachedRing{segment, writer_pid, writer_start, std::move(mapped), reader, reader.published()});
  } catch (const std::exception& e) {
    return refuse(e.what());
  }
  std::vector<std::shared_ptr<AttachedRing>> gone;
  std::string reason;
  {
    std::lock_guard lock(mu_);
    for (auto it = rings_.begin(); it != rings_.end();) {
      if (process_start_ticks((*it)->writer_pid) == (*it)->writer_start) {
        ++it;
        continue;
      }
      gone.push_back(std::move(*it));
      it = rings_.erase(it);
    }
    bool known = false;
    for (const auto& r : rings_) {
      if (r->name != ring->name) continue;
      ++r->attached;  // already reading it (a second subscribe of the same port, soon refused)
      known = true;
    }
    if (!known && rings_.size() >= kMaxRings) {
      reason = "already " + std::to_string(kMaxRings) + " shared-memory publishers, the most a port reads";
    } else if (!known) {
      if (acts_on_arrival_locked()) start_waiter_locked(*ring);
      rings_.push_back(std::move(ring));
    }
  }
  for (auto& r : gone)
    if (r->has_waiter) stop_waiter(*r, false);
  if (!reason.empty()) return refuse(reason);
  why = CORBA::string_dup("");
  return true;
}

CORBA::Boolean InPortBase::detach_ring(const char* segment) {
  std::shared_ptr<AttachedRing> gone;
  {
    std::lock_guard lock(mu_);
    const auto it = std::find_if(rings_.begin(), rings_.end(), [&](const auto& r) { return r->name == segment; });
    if (it == rings_.end()) return false;
    if (--(*it)->attached > 0) return true;
    if (!(*it)->has_waiter) {
      take_from_ring_locked(**it);  // what was written before the unsubscribe still counts
      rings_.erase(it);
      return true;
    }
    gone = std::move(*it);
    rings_.erase(it);
  }
  stop_waiter(*gone, true);  // outside mu_: the waiter may be storing, which takes it
  return true;
}

std::size_t InPortBase::attached_rings() const {
  std::lock_guard lock(mu_);
  return rings_.size();
}

std::size_t InPortBase::ring_waiters() const {
  std::lock_guard lock(mu_);
  return static_cast<std::size_t>(std::count_if(rings_.begin(), rings_.end(), [](const auto& r) { return r->has_waiter; }));
}

void InPortBase::start_waiter_locked(AttachedRing& ring) {
  ring.has_waiter = true;
  ring.waiter = std::thread(&InPortBase::waiter_loop, this, &ring);
  pthread_setname_np(ring.waiter.native_handle(), "rtm-ring-wait");  // here: seen once attach_ring returns
  // Data pass this thread between the publisher and the port's reader: with real-time
  // priorities on it runs at the path's (rt/thread.h), as a delivery thread does.
  if (const int priority = path_thread_priority(); priority > 0) set_thread_fifo_priority(ring.waiter.native_handle(), priority);
}

void InPortBase::waiter_loop(AttachedRing* ring) {
  // One futex wait per datum (or per batch the writer got ahead by), no timer: a detach wakes
  // it through the ring's own word (ShmRingReader::interrupt).
  while (!ring->stop.load(std::memory_order_acquire)) {
    if (!ring->reader.wait_for_data(ShmRingReader::kNoDeadline, &ring->stop)) continue;
    // A head ahead of every datum the slots hold (a ring someone wrote over by hand) would
    // wake it at once, again and again, at a real-time priority: it backs off instead.
    if (store_from_ring(*ring) == 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

void InPortBase::stop_waiter(AttachedRing& ring, bool keep_rest) {
  ring.stop.store(true, std::memory_order_seq_cst);
  ring.reader.interrupt();
  if (ring.waiter.joinable()) ring.waiter.join();
  if (keep_rest) store_from_ring(ring);
}

void InPortBase::stop_ring_waiters() {
  std::vector<std::shared_ptr<AttachedRing>> gone;
  {
    std::lock_guard lock(mu_);
    for (auto it = rings_.begin(); it != rings_.end();) {
      if (!(*it)->has_waiter) {
        ++it;
        continue;
      }
      gone.push_back(std::move(*it));
      it = rings_.erase(it);
    }
  }
  for (auto& r : gone) stop_waiter(*r, false);
}

// The POA is called with activation_mu_ held but never with the registry lock held, so the
// POA's locks and the registry's are never taken in opposite orders.
RTM::InPortEx_ptr InPortBase::activate(Orb& orb) {
  std::lock_guard activation(activation_mu_);
  if (!active_.load()) {
    CORBA::Object_var obj = orb.activate(this);
    RTM::InPortEx_var ref = RTM::InPortEx::_narrow(obj);
    {
      std::lock_guard lock(registry_mu());
      ref_ = RTM::InPortEx::_duplicate(ref.in());
      orb_ = &orb;
      registry().push_back({this, CORBA::Object::_duplicate(ref.in())});
      active_.store(true, std::memory_order_release);
    }
  }
  return reference();
}

void InPortBase::deactivate() {
  std::lock_guard activation(activation_mu_);
  Orb* orb = nullptr;
  {
    std::lock_guard lock(registry_mu());
    if (!active_.load()) return;
    active_.store(false, std::memory_order_release);
    auto& entries = registry();
    entries.erase(
        std::remove_if(entries.begin(), entries.end(), [this](const LocalEntry& e) { return e.port == this; }),
        entries.end());
    orb = orb_;
  }
  stop_ring_waiters();  // no datum is stored on arrival, and no callback runs, from now on
  // After the Orb is gone its POA has already released every servant.
  if (Orb::instance() == orb) orb->deactivate(this);
}

RTM::InPortEx_ptr InPortBase::reference() const {
  std::lock_guard lock(registry_mu());
  return RTM::InPortEx::_duplicate(ref_.in());
}

void check_port_info(const std::string& port, std::size_t element_count, const PortInfo& info) {
  if (info.elements.empty() || element_count == 0 || info.elements.size() == element_count) return;
  throw std::invalid_argument(port + ": " + std::to_string(info.elements.size()) + " elements described, but a datum holds " +
                              std::to_string(element_count));
}

RTM::PortDescription* to_idl(const PortInfo& info) {
  auto* out = new RTM::PortDescription;
  out->description = info.description.c_str();
  out->elements.length(static_cast<CORBA::ULong>(info.elements.size()));
  for (CORBA::ULong i = 0; i < out->elements.length(); ++i) {
    out->elements[i].name = info.elements[i].name.c_str();
    out->elements[i].unit = info.elements[i].unit.c_str();
  }
  return out;
}

void InPortBase::set_info(PortInfo info) {
  check_port_info(full_name(), element_count(), info);
  info_ = std::move(info);
}

RTM::PortDescription* InPortBase::describe() { return to_idl(info_); }

char* InPortBase::name() { return CORBA::string_dup(name_.c_str()); }
CORBA::TypeCode_ptr InPortBase::port_type() { return CORBA::TypeCode::_duplicate(type_code()); }
char* InPortBase::owner() { return CORBA::string_dup(owner_.c_str()); }

RTM::PortCounters InPortBase::counters() {
  const InPortCounters c = counters_snapshot();
  RTM::PortCounters out{};
  out.accepted = c.accepted;
  out.rejected = c.rejected;
  out.dropped = c.dropped;
  out.pushed = 0;
  out.failed = 0;
  return out;
}

char* InPortBase::last_error() { return CORBA::string_dup(last_error_text().c_str()); }

void InPortBase::push(const CORBA::Any& value) {
  try {
    put(value);
  } catch (const CORBA::BAD_PARAM&) {
    // Already counted and remembered by reject(); a oneway has nobody to tell.
  }
}

void InPortBase::push_in_order(const CORBA::Any& value, CORBA::ULongLong sender, CORBA::ULongLong seq) {
  try {
    put_in_order(value, sender, seq);
  } catch (const CORBA::BAD_PARAM&) {
    // As push().
  }
}

void InPortBase::reject(CORBA::TypeCode_ptr got) {
  rejected_.fetch_add(1, std::memory_order_relaxed);
  std::string why = "put on " + full_name() + ": expected " + type_name(type_code()) + ", got " + type_name(got);
  std::lock_guard lock(mu_);
  // One line per distinct reason: a publisher of the wrong type must not flood the log.
  if (why != last_error_) log().warn("{} (BAD_PARAM)", why);
  last_error_ = std::move(why);
}

void InPortBase::notify_arrival() {
  if (signal_) signal_->notify();
  if (awaiting_ > 0) {
    arrival_cv_.notify_all();
    if (awaited_ring_ != nullptr) {  // it waits on the ring's word
      await_cancel_.store(true, std::memory_order_seq_cst);
      awaited_ring_->reader.interrupt();
    }
  }
}

std::size_t InPortBase::awaiting() const {
  std::lock_guard lock(mu_);
  return static_cast<std::size_t>(awaiting_);
}

InPortBase::Awaited InPortBase::wait_new_until(std::int64_t deadline_ns) {
  std::unique_lock lock(mu_);
  ++awaiting_;
  bool ready = false, waited = false;
  while (!(ready = has_unread_locked()) && monotonic_ns() < deadline_ns) {
    // The sole publisher's ring, read in read(): wait on its futex word for its next datum.
    if (rings_.size() == 1 && !rings_.front()->has_waiter) {
      const std::shared_ptr<AttachedRing> ring = rings_.front();  // stays mapped if detached meanwhile
      const std::uint64_t seen = ring->reader.last_taken();
      awaited_ring_ = ring.get();
      waited = true;
      await_cancel_.store(false, std::memory_order_seq_cst);
      lock.unlock();
      const bool published = ring->reader.wait_past(seen, deadline_ns, &await_cancel_);
      lock.lock();
      if (awaited_ring_ == ring.get()) awaited_ring_ = nullptr;
      // A head past every datum the slots hold (a ring someone wrote over by hand) would
      // return at once, again and again: nothing new to take from it is nothing new.
      if (published && !(ready = has_unread_locked())) break;
      continue;
    }
    // Puts, in-process deliveries and rings with a waiter of their own notify the condition
    // variable; with several rings read in read() it looks at them again every 50 us.
    const std::int64_t until = rings_.empty() ? deadline_ns : std::min(deadline_ns, monotonic_ns() + 50'000);
    waited = true;
    arrival_cv_.wait_until(lock, std::chrono::steady_clock::time_point(std::chrono::nanoseconds(until)));
  }
  --awaiting_;
  if (!ready) return Awaited::none;
  return waited ? Awaited::arrived : Awaited::there;
}

void InPortBase::callback_failed(const char* what) {
  if (callback_failures_.fetch_add(1, std::memory_order_relaxed) == 0)
    log().error("{}: callback threw: {} (further failures are only counted)", full_name(), what);
}

}  // namespace rtm
