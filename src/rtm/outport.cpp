// SPDX-License-Identifier: Apache-2.0
#include "rtm/outport.h"

#include "rtm/data.h"
#include "rtm/log.h"
#include "rtm/orb.h"

#include <algorithm>
#include <stdexcept>

namespace rtm {

OutPortBase::OutPortBase(std::string name, std::string owner, OutPortOptions options)
    : name_(std::move(name)), owner_(std::move(owner)), options_(options), delivery_(options.delivery), shared_memory_(options.shared_memory) {
  host_.name = full_name();
  host_.max_failures = options_.max_failures;
  host_.oneway = options_.oneway;
  host_.writer_call_timeout_ms = options_.writer_call_timeout_ms;
  host_.retire = [this](Connection* c) { retire(c); };
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
  c.dropped = host_.dropped.load(std::memory_order_relaxed);
  c.pushed = host_.pushed.load(std::memory_order_relaxed) + host_.ring_pushed.load(std::memory_order_relaxed);
  c.failed = host_.failed.load(std::memory_order_relaxed);
  c.timed_out = host_.timed_out.load(std::memory_order_relaxed);
  c.by_writer = host_.by_writer.load(std::memory_order_relaxed);
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

std::string OutPortBase::last_error_text() const {
  std::lock_guard lock(mu_);
  return last_error_;
}

void OutPortBase::derive_stamp_from(const std::vector<const InPortBase*>& inputs) {
  const std::string who = full_name() + ": deriving its stamp";
  if (!inputs.empty() && !stamped()) throw std::invalid_argument(who + ": its datum carries no stamp (tm)");
  if (inputs.size() > kMaxStampSources)
    throw std::invalid_argument(who + " from " + std::to_string(inputs.size()) + " InPorts: at most " +
                                std::to_string(kMaxStampSources));
  for (const InPortBase* in : inputs) {
    if (in == nullptr) throw std::invalid_argument(who + ": no InPort");
    if (!in->stamped())
      throw std::invalid_argument(who + " from " + in->port_name() + ": that port's datum carries no stamp (tm)");
  }
  std::copy(inputs.begin(), inputs.end(), stamp_sources_.begin());
  stamp_source_count_ = inputs.size();
}

std::string OutPortBase::stamp_sources_text() const {
  std::string out;
  for (std::size_t i = 0; i < stamp_source_count_; ++i) out += (i ? "+" : "") + stamp_sources_[i]->port_name();
  return out;
}

std::int64_t OutPortBase::derived_stamp_ns() const {
  std::int64_t oldest = 0;
  for (std::size_t i = 0; i < stamp_source_count_; ++i) {
    const InPortBase& in = *stamp_sources_[i];
    if (in.stamps_taken() == 0 || in.last_stamp_ns() <= 0) continue;  // none read yet, or unstamped (0)
    if (oldest == 0 || in.last_stamp_ns() < oldest) oldest = in.last_stamp_ns();
  }
  return oldest;
}

std::string OutPortBase::full_port_text() const {
  return "already " + std::to_string(options_.max_subscriptions) +
         " subscriptions, the most it takes (OutPortOptions::max_subscriptions)";
}

std::size_t OutPortBase::subscription_count() const {
  std::lock_guard lock(mu_);
  return conns_.size();
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

void OutPortBase::stop_and_join(std::unique_ptr<Connection> c, std::vector<std::unique_ptr<Connection>>& parked) {
  if (!c->stop_and_join()) parked.push_back(std::move(c));
}

void OutPortBase::close() {
  std::vector<std::unique_ptr<Connection>> all;
  {
    std::lock_guard lock(mu_);
    closed_ = true;
    for (auto& c : conns_) all.push_back(std::move(c));
    for (auto& c : retired_) all.push_back(std::move(c));
    conns_.clear();
    retired_.clear();
    conns_changed_locked();
  }
  std::vector<std::unique_ptr<Connection>> parked;
  for (auto& c : all) stop_and_join(std::move(c), parked);
  for (auto& c : parked) c->detach_thread();
}

void OutPortBase::reap_retired() {
  std::vector<std::unique_ptr<Connection>> dead;
  {
    std::lock_guard lock(mu_);
    dead.swap(retired_);
  }
  std::vector<std::unique_ptr<Connection>> parked;
  for (auto& c : dead) stop_and_join(std::move(c), parked);
  if (!parked.empty()) {
    std::lock_guard lock(mu_);
    for (auto& c : parked) retired_.push_back(std::move(c));
  }
}

bool OutPortBase::add_connection(std::unique_ptr<Connection> connection) {
  std::string why;
  {
    std::lock_guard lock(mu_);
    const std::string& peer = connection->subscriber().peer;
    if (closed_) {
      why = full_name() + " -> " + peer + ": the OutPort is closed";
    } else if (conns_.size() >= options_.max_subscriptions) {
      why = full_name() + " -> " + peer + ": " + full_port_text();
    } else if (std::any_of(conns_.begin(), conns_.end(), [&](const auto& c) { return c->same_subscriber(*connection); })) {
      why = full_name() + " -> " + peer + ": already subscribed";
    } else {
      Connection* raw = connection.get();
      conns_.push_back(std::move(connection));
      conns_changed_locked();
      raw->start();  // under mu_: a write() sees it only with its thread there
      return true;
    }
  }
  connection->stop_and_join();  // never started: a ring's subscriber is told to detach
  refuse(why);
  return false;
}

bool OutPortBase::remove_matching(const std::function<bool(const Connection&)>& match) {
  reap_retired();
  std::vector<std::unique_ptr<Connection>> victims;
  {
    std::lock_guard lock(mu_);
    for (std::size_t i = 0; i < conns_.size();) {
      if (match(*conns_[i])) {
        victims.push_back(std::move(conns_[i]));
        conns_.erase(conns_.begin() + static_cast<std::ptrdiff_t>(i));
      } else {
        ++i;
      }
    }
    conns_changed_locked();
  }
  std::vector<std::unique_ptr<Connection>> parked;
  const bool removed = !victims.empty();
  for (auto& v : victims) stop_and_join(std::move(v), parked);
  if (!parked.empty()) {
    std::lock_guard lock(mu_);
    for (auto& c : parked) retired_.push_back(std::move(c));
  }
  return removed;
}

void OutPortBase::retire(Connection* c) {
  std::lock_guard lock(mu_);
  for (std::size_t i = 0; i < conns_.size(); ++i) {
    if (conns_[i].get() == c) {
      retire_locked(i);
      return;
    }
  }
  // Not listed any more: unsubscribe() or close() took it and joins this thread.
}

void OutPortBase::retire_locked(std::size_t index) {
  retired_.push_back(std::move(conns_[index]));
  conns_.erase(conns_.begin() + static_cast<std::ptrdiff_t>(index));
  conns_changed_locked();
}

void OutPortBase::conns_changed_locked() {
  const auto calling = std::count_if(conns_.begin(), conns_.end(), [](const auto& c) { return c->calls_or_queues(); });
  calling_connections_.store(static_cast<std::uint32_t>(calling), std::memory_order_relaxed);
}

bool OutPortBase::admitted(const Subscriber& who) {
  if (CORBA::is_nil(who.port_ex)) return true;
  try {
    who.port_ex->admit_writer();
  } catch (const CORBA::NO_PERMISSION& e) {
    refuse(full_name() + " -> " + who.peer + ": " + access_refusal_text(e.minor()));
    return false;
  } catch (const CORBA::Exception&) {
    // Not answering now is found out by the first write(), as for any subscriber.
  }
  return true;
}

ConnPolicy OutPortBase::resolve(const ConnPolicy& asked) const {
  ConnPolicy p = asked;
  if (p.depth == 0) p.depth = std::max<std::uint32_t>(options_.queue_depth, 1);
  if (p.call_timeout_ms == 0) p.call_timeout_ms = options_.call_timeout_ms;
  if (p.delivery == ConnPolicy::Delivery::port_default)
    p.delivery = delivery() == OutPortOptions::Delivery::thread ? ConnPolicy::Delivery::thread
                                                                 : ConnPolicy::Delivery::writer_when_idle;
  if (p.once) p.delivery = ConnPolicy::Delivery::thread;
  return p;
}

bool OutPortBase::depth_allowed(const ConnPolicy& asked) {
  if (asked.depth <= ConnPolicy::kMaxDepth) return true;
  refuse(full_name() + ": depth " + std::to_string(asked.depth) + " is above " + std::to_string(ConnPolicy::kMaxDepth) +
         " (ConnPolicy::kMaxDepth)");
  return false;
}

bool OutPortBase::reader_matches(Subscriber& who) {
  const InPortBase* local = who.local.in();
  const ReaderPolicy& wanted = who.policy.reader;
  ReaderPolicy kept;  // any: untold, or a text this build cannot read (satisfies nothing asked)
  if (local != nullptr) {
    kept = local->reader();
    who.reader = to_string(kept);
  } else if (!CORBA::is_nil(who.port_ex)) {
    try {
      CORBA::String_var told = who.port_ex->reader_policy();
      who.reader = told.in();
      kept = parse_reader_policy(who.reader);
    } catch (const std::invalid_argument&) {
    } catch (const CORBA::Exception& e) {
      // An InPortEx of an older build: it keeps something, but does not tell what.
      if (wanted.kind == ReaderPolicy::Kind::any) return true;
      refuse(full_name() + " -> " + who.peer + ": the InPort does not tell what it keeps (" + e._name() +
             "), and the connection asks reader=" + to_string(wanted));
      return false;
    }
  }
  if (wanted.kind == ReaderPolicy::Kind::any) return true;
  if (who.reader.empty()) {
    refuse(full_name() + " -> " + who.peer + ": a 2004 InPort does not tell what it keeps, and the connection asks reader=" +
           to_string(wanted));
    return false;
  }
  if (kept.kind == ReaderPolicy::Kind::any || !satisfies(kept, wanted)) {
    refuse(full_name() + " -> " + who.peer + ": the InPort keeps " + who.reader + ", the connection asks reader=" +
           to_string(wanted));
    return false;
  }
  return true;
}

void OutPortBase::refuse(const std::string& why) {
  refused_.fetch_add(1, std::memory_order_relaxed);
  log().warn("subscribe refused: {}", why);
  std::lock_guard lock(mu_);
  last_error_ = why;
}

void OutPortBase::refuse_types(const std::string& peer, CORBA::TypeCode_ptr their_type) {
  refuse(full_name() + " (" + type_name(type_code()) + ") -> " + peer + " (" + type_name(their_type) + "): types differ");
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
  return remove_matching([&](const Connection& c) { return c.is(r_type == RTM::once, i_port, local.in()); });
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
  list->length(static_cast<CORBA::ULong>(conns_.size()));
  for (CORBA::ULong i = 0; i < conns_.size(); ++i) conns_[i]->describe((*list)[i]);
  return list;
}

char* OutPortBase::last_error() { return CORBA::string_dup(last_error_text().c_str()); }

}  // namespace rtm
