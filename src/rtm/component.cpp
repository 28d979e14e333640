// SPDX-License-Identifier: Apache-2.0
#include "rtm/component.h"

#include "rtm/log.h"
#include "rtm/orb.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <stdexcept>
#include <tuple>

namespace rtm {

// ============================ Component ===============================

Component::Component(std::string name, std::string kind) : name_(std::move(name)), kind_(std::move(kind)) {
  if (name_.empty()) throw std::invalid_argument("Component: empty name (kind '" + kind_ + "')");
}

Component::~Component() {
  for (auto* port : out_ptrs_) port->close();
}

namespace {
template <class List>
void check_new_name(const List& list, const std::string& what, const std::string& owner, const std::string& name) {
  if (name.empty()) throw std::invalid_argument(owner + ": " + what + " with an empty name");
  if (std::any_of(list.begin(), list.end(), [&](const auto& e) { return e.name == name; }))
    throw std::invalid_argument(owner + ": " + what + " '" + name + "' declared twice");
}
}  // namespace

void Component::add_statistic(std::string stat_name, std::string unit, std::string text,
                              std::function<double()> read) {
  check_new_name(statistics_, "statistic", name_, stat_name);
  if (!read) throw std::invalid_argument(name_ + ": statistic '" + stat_name + "' has no read function");
  statistics_.push_back({std::move(stat_name), std::move(unit), std::move(text), std::move(read)});
}

void Component::add_counters(const CounterSet& set) {
  for (const Counter* counter : set.all())
    add_statistic(counter->name(), "", counter->description(), [counter] { return static_cast<double>(counter->value()); });
}

void Component::add_percentile_statistics(const std::string& stat, const std::string& span,
                                          const LatencyHistogram& h) {
  for (const auto& [suffix, what, q] :
       {std::tuple{"_p50", "median", 0.5}, {"_p99", "99th percentile", 0.99}, {"_max", "maximum", 1.0}}) {
    add_statistic(stat + suffix, "us", span + ", " + what, [&h, q = q] {
      return static_cast<double>(q >= 1.0 ? h.max_ns() : h.percentile_ns(q)) / 1000.0;
    });
  }
}

void Component::add_process_statistic() {
  const auto pid = static_cast<double>(::getpid());
  add_statistic("pid", "", "the process the component runs in", [pid] { return pid; });
}

void Component::add_out_port_statistics() {
  for (OutPortBase* port : out_ptrs_) {
    const std::string& name = port->port_name();
    add_percentile_statistics(name + ".write", "time write() held the activity", port->write_cost_histogram());
    add_statistic(name + ".by_writer", "", "data write() delivered itself (no thread wake-up)",
                  [port] { return static_cast<double>(port->counters_snapshot().by_writer); });
    add_statistic(name + ".timed_out", "", "remote calls that outlived their bound (their data's fate unknown)",
                  [port] { return static_cast<double>(port->counters_snapshot().timed_out); });
  }
}

void Component::add_parameter(Parameter parameter) {
  check_new_name(parameters_, "parameter", name_, parameter.name);
  if (!parameter.get) throw std::invalid_argument(name_ + ": parameter '" + parameter.name + "' has no get function");
  if (parameter.access != ParameterAccess::fixed && !parameter.set)
    throw std::invalid_argument(name_ + ": writable parameter '" + parameter.name + "' has no set function");
  parameters_.push_back(std::move(parameter));
}

// ============================ ComponentServant ========================

ComponentServant::ComponentServant(std::unique_ptr<Component> component, ActivitySpec activity)
    : component_(std::move(component)), spec_(std::move(activity)) {
  if (!component_) throw std::invalid_argument("ComponentServant: no component");
  CycleFunction cycle = [this](const CycleContext& ctx) { return run_cycle(ctx); };
  if (auto* periodic = std::get_if<PeriodicOptions>(&spec_)) {
    PeriodicOptions options = *periodic;
    if (options.thread_name == PeriodicOptions{}.thread_name) options.thread_name = component_->name();
    activity_ = std::make_unique<PeriodicActivity>(std::move(cycle), std::move(options));
  } else if (auto* arrival = std::get_if<OnArrival>(&spec_)) {
    const auto& ins = component_->in_ports();
    if (arrival->in_port_index >= ins.size())
      throw std::invalid_argument("ComponentServant " + component_->name() + ": OnArrival names in port " +
                                  std::to_string(arrival->in_port_index) + " but the component has " +
                                  std::to_string(ins.size()));
    arrival_ = std::make_shared<ArrivalSignal>();
    ins[arrival->in_port_index]->set_arrival_signal(arrival_);
    activity_ = std::make_unique<OnArrivalActivity>(std::move(cycle), arrival_, component_->name());
  }
}

ComponentServant::~ComponentServant() {
  holds_.reset();
  off();
  deactivate();
  if (arrival_)
    for (auto* port : component_->in_ports()) port->set_arrival_signal(nullptr);
  activity_.reset();
}

void ComponentServant::hold(const char* holder, CORBA::ULong lease_ms) {
  if (!holds_) throw CORBA::NO_IMPLEMENT(0, CORBA::COMPLETED_NO);
  try {
    holds_->hold(holder, lease_ms);
  } catch (const std::invalid_argument& e) {
    log().warn("{}: hold by {} refused: {}", component_->name(), holder, e.what());
    throw CORBA::BAD_PARAM(0, CORBA::COMPLETED_NO);
  }
}

void ComponentServant::release(const char* holder) {
  if (!holds_) throw CORBA::NO_IMPLEMENT(0, CORBA::COMPLETED_NO);
  holds_->release(holder);
}

RTM::RtComponentEx_ptr ComponentServant::activate(Orb& orb) {
  for (auto* port : component_->in_ports()) CORBA::release(port->activate(orb));
  for (auto* port : component_->out_ports()) CORBA::release(port->activate(orb));
  std::lock_guard lock(refs_mu_);
  if (CORBA::is_nil(ref_)) {
    CORBA::Object_var obj = orb.activate(this);
    ref_ = RTM::RtComponentEx::_narrow(obj);
    orb_ = &orb;
  }
  return RTM::RtComponentEx::_duplicate(ref_.in());
}

void ComponentServant::deactivate() {
  Orb* orb = nullptr;
  {
    std::lock_guard lock(refs_mu_);
    if (!CORBA::is_nil(ref_)) {
      ref_ = RTM::RtComponentEx::_nil();
      orb = orb_;
      orb_ = nullptr;
    }
  }
  // After the Orb is gone its POA has already released every servant.
  if (orb && Orb::instance() == orb) orb->deactivate(this);
  for (auto* port : component_->in_ports()) port->deactivate();
  for (auto* port : component_->out_ports()) port->deactivate();
}

RTM::RtComponentEx_ptr ComponentServant::reference() const {
  std::lock_guard lock(refs_mu_);
  return RTM::RtComponentEx::_duplicate(ref_.in());
}

std::string ComponentServant::error_text() const {
  std::lock_guard lock(error_mu_);
  return error_;
}

CycleFunction ComponentServant::cycle_function() {
  return [this](const CycleContext& ctx) { return run_cycle(ctx); };
}

void ComponentServant::set_timing_source(const Activity* activity) { timing_source_ = activity; }

void ComponentServant::expose_in_port(std::size_t index, RTM::InPort_ptr ref) {
  std::lock_guard lock(refs_mu_);
  const std::size_t size = std::max(in_overrides_.size(), component_->in_ports().size());
  if (index > size)
    throw std::out_of_range("ComponentServant " + component_->name() + ": expose_in_port index " +
                            std::to_string(index) + " beyond " + std::to_string(size) + " ports");
  if (in_overrides_.size() <= index) in_overrides_.resize(std::max(index + 1, size));
  in_overrides_[index] = RTM::InPort::_duplicate(ref);
}

void ComponentServant::await_before_cycle(InPortBase& port, std::int64_t bound_ns) {
  if (bound_ns <= 0) throw std::invalid_argument(component_->name() + ": an await bound must be above 0");
  if (!std::holds_alternative<PeriodicOptions>(spec_))
    throw std::invalid_argument(component_->name() + ": only a periodic cycle awaits a datum before it runs");
  await_port_ = &port;
  await_bound_ns_ = bound_ns;
  component_->add_counters(await_counters_);
}

bool ComponentServant::run_cycle(const CycleContext& ctx) {
  const RTM::ComponentState state = state_.load();
  if (state != RTM::COMPONENT_ON) return state != RTM::COMPONENT_ERROR;
  if (observer_ != nullptr) observer_->cycle(ctx);
  if (await_port_ != nullptr) {
    switch (await_port_->wait_new_until(ctx.deadline_ns + await_bound_ns_)) {
      case InPortBase::Awaited::there: break;
      case InPortBase::Awaited::arrived: await_counters_.arrived.add(); break;
      case InPortBase::Awaited::none: await_counters_.missed.add(); break;
    }
  }
  // The cycle starts once its datum is there, or (a member of a shared tick) once the members
  // before it on the tick are done: the budget is the component's own time.
  const bool own_start = await_port_ != nullptr || std::holds_alternative<ExternalTick>(spec_);
  const std::int64_t start_ns = watched_ && own_start ? monotonic_ns() : ctx.wake_ns;
  try {
    component_->on_cycle(ctx);
    // Why a contract that says brake stops the component now; empty when none does.
    std::string brake = chains_.empty() ? std::string() : record_chains(ctx.cycle);
    if (watched_ && brake.empty()) brake = record_contract(ctx, start_ns);
    if (brake.empty()) return true;
    fail(brake + " (on miss: brake)");
  } catch (const std::exception& e) {
    fail(std::string("cycle ") + std::to_string(ctx.cycle) + " threw: " + e.what());
  } catch (const CORBA::Exception& e) {
    fail(std::string("cycle ") + std::to_string(ctx.cycle) + " raised CORBA " + e._name());
  } catch (...) {
    fail(std::string("cycle ") + std::to_string(ctx.cycle) + " threw an unknown exception");
  }
  // A component in error must stop acting (e.g. command zero velocity): give it on_stop().
  try {
    component_->on_stop();
  } catch (const std::exception& e) {
    log().error("{}: on_stop after the error threw too: {}", component_->name(), e.what());
  } catch (...) {
    log().error("{}: on_stop after the error threw too", component_->name());
  }
  return false;
}

void ComponentServant::watch_contract(const TimingContract& contract) {
  contract_ = contract;
  watch_.set_limits({contract.budget_ns, contract.effective_deadline_ns()});
  if (watched_) return;
  watched_ = true;
  component_->add_percentile_statistics("cycle_time", "one cycle, from its start to its end", watch_.cycle_histogram());
  component_->add_percentile_statistics("response", "from a cycle's release to its end", watch_.response_histogram());
  component_->add_statistic("over_budget", "", "cycles that ran longer than the contract's budget",
                            [this] { return static_cast<double>(watch_.over_budget()); });
  component_->add_statistic("missed_deadline", "", "cycles that ended after the contract's deadline",
                            [this] { return static_cast<double>(watch_.missed_deadline()); });
}

void ComponentServant::watch_chain(ChainWatch watch) {
  if (watch.port == nullptr || !watch.port->stamped())
    throw std::invalid_argument(component_->name() + ": chain " + watch.name + ": " +
                                (watch.port ? watch.port->port_name() + "'s datum carries no stamp (tm)"
                                            : std::string("no InPort")));
  for (const auto& c : chains_)
    if (c->watch.name == watch.name)
      throw std::invalid_argument(component_->name() + ": chain " + watch.name + " watched twice");
  auto& c = *chains_.emplace_back(std::make_unique<WatchedChain>());
  c.watch = std::move(watch);
  const std::string stat = "chain." + c.watch.name;
  component_->add_percentile_statistics(stat + ".latency", "from a sample to the end of the first cycle using it",
                                        c.latency);
  component_->add_statistic(stat + ".age_p99", "us", "age of the data a cycle acted on, p99",
                            [&c] { return static_cast<double>(c.age.percentile_ns(0.99)) / 1e3; });
  component_->add_statistic(stat + ".age_max", "us", "age of the data a cycle acted on, max",
                            [&c] { return static_cast<double>(c.age.max_ns()) / 1e3; });
  component_->add_statistic(stat + ".late", "", "data that reached the chain's end after its deadline",
                            [&c] { return static_cast<double>(c.late.load(std::memory_order_relaxed)); });
  component_->add_statistic(stat + ".stale", "", "cycles that acted on data older than the chain's max age",
                            [&c] { return static_cast<double>(c.stale.load(std::memory_order_relaxed)); });
}

// One clock read for all the chains; nothing allocated, no lock (but the words of a brake).
std::string ComponentServant::record_chains(std::uint64_t cycle) {
  const std::int64_t now = realtime_ns();
  std::string brake;
  for (auto& chain : chains_) {
    WatchedChain& c = *chain;
    const InPortBase& port = *c.watch.port;
    if (port.stamps_taken() == 0 || port.last_expired()) continue;
    const std::int64_t age = now - port.last_stamp_ns();
    bool late = false;
    if (port.stamps_taken() != c.seen) {
      c.seen = port.stamps_taken();
      c.latency.record(age);
      late = c.watch.deadline_ns > 0 && age > c.watch.deadline_ns;
      if (late) c.late.fetch_add(1, std::memory_order_relaxed);
    }
    c.age.record(age);
    const bool stale = c.watch.max_age_ns > 0 && age > c.watch.max_age_ns;
    if (stale) c.stale.fetch_add(1, std::memory_order_relaxed);
    if ((late || stale) && c.watch.on_miss == MissAction::brake && brake.empty())
      brake = "cycle " + std::to_string(cycle) + " acted on chain " + c.watch.name + "'s data " + format_duration(age) +
              " after their sample, past its " + (late ? "deadline of " + format_duration(c.watch.deadline_ns)
                                                        : "max age of " + format_duration(c.watch.max_age_ns));
  }
  return brake;
}

std::string ComponentServant::record_contract(const CycleContext& ctx, std::int64_t start_ns) {
  const std::int64_t end_ns = monotonic_ns();
  const CycleVerdict verdict = watch_.record(ctx.deadline_ns, start_ns, end_ns);
  if (contract_.on_miss != MissAction::brake || (!verdict.over_budget && !verdict.missed_deadline)) return {};
  std::string why = "cycle " + std::to_string(ctx.cycle);
  if (verdict.over_budget)
    why += " ran " + format_duration(end_ns - start_ns) + ", over its budget of " + format_duration(contract_.budget_ns);
  if (verdict.missed_deadline)
    why += std::string(verdict.over_budget ? " and" : "") + " ended " + format_duration(end_ns - ctx.deadline_ns) +
           " after its release, past its deadline of " + format_duration(contract_.effective_deadline_ns());
  return why;
}

std::vector<ComponentServant::ChainStatus> ComponentServant::chain_status() const {
  std::vector<ChainStatus> out;
  for (const auto& c : chains_)
    out.push_back({c->watch.name, c->watch.on_miss, c->late.load(std::memory_order_relaxed),
                   c->stale.load(std::memory_order_relaxed), c->latency.max_ns(), c->age.max_ns()});
  return out;
}

void ComponentServant::fail(const std::string& why) {
  {
    std::lock_guard lock(error_mu_);
    error_ = why;
  }
  state_.store(RTM::COMPONENT_ERROR);
  log().error("{} ({}) -> COMPONENT_ERROR: {}", component_->name(), component_->kind(), why);
}

void ComponentServant::on() {
  std::lock_guard lock(control_mu_);
  const RTM::ComponentState state = state_.load();
  if (state == RTM::COMPONENT_ERROR) {
    log().warn("{}: on() refused in COMPONENT_ERROR ({}); reset() first", component_->name(), error_text());
    throw CORBA::BAD_INV_ORDER(kMinorComponentError, CORBA::COMPLETED_NO);
  }
  if (state == RTM::COMPONENT_ON) return;
  if (activity_) activity_->stop();  // joins a thread that ended by itself
  if (observer_ != nullptr) observer_->starting();
  try {
    component_->on_start();
  } catch (const std::exception& e) {
    fail(std::string("on_start threw: ") + e.what());
    throw CORBA::BAD_INV_ORDER(kMinorComponentError, CORBA::COMPLETED_NO);
  } catch (...) {
    fail("on_start threw an unknown exception");
    throw CORBA::BAD_INV_ORDER(kMinorComponentError, CORBA::COMPLETED_NO);
  }
  state_.store(RTM::COMPONENT_ON);
  if (activity_) activity_->start();
}

void ComponentServant::off() {
  std::lock_guard lock(control_mu_);
  // The activity stops first: a cycle it counts is then always one on_cycle() ran, never one
  // that found the state already OFF.
  if (activity_) activity_->stop();
  RTM::ComponentState expected = RTM::COMPONENT_ON;
  if (!state_.compare_exchange_strong(expected, RTM::COMPONENT_OFF)) return;
  if (observer_ != nullptr) observer_->stopping();
  try {
    component_->on_stop();
  } catch (const std::exception& e) {
    fail(std::string("on_stop threw: ") + e.what());
  } catch (...) {
    fail("on_stop threw an unknown exception");
  }
}

RTM::InPortList* ComponentServant::in_ports() {
  auto* list = new RTM::InPortList;
  const auto& own = component_->in_ports();
  std::lock_guard lock(refs_mu_);
  const std::size_t size = std::max(in_overrides_.size(), own.size());
  list->length(static_cast<CORBA::ULong>(size));
  for (std::size_t i = 0; i < size; ++i) {
    if (i < in_overrides_.size() && !CORBA::is_nil(in_overrides_[i])) {
      (*list)[static_cast<CORBA::ULong>(i)] = RTM::InPort::_duplicate(in_overrides_[i].in());
    } else if (i < own.size()) {
      (*list)[static_cast<CORBA::ULong>(i)] = own[i]->reference();
    }
  }
  return list;
}

RTM::OutPortList* ComponentServant::out_ports() {
  auto* list = new RTM::OutPortList;
  const auto& own = component_->out_ports();
  list->length(static_cast<CORBA::ULong>(own.size()));
  for (std::size_t i = 0; i < own.size(); ++i) (*list)[static_cast<CORBA::ULong>(i)] = own[i]->reference();
  return list;
}

char* ComponentServant::name() { return CORBA::string_dup(component_->name().c_str()); }
char* ComponentServant::kind() { return CORBA::string_dup(component_->kind().c_str()); }
RTM::ComponentState ComponentServant::state() { return state_.load(); }
char* ComponentServant::last_error() { return CORBA::string_dup(error_text().c_str()); }

void ComponentServant::reset() {
  std::lock_guard lock(control_mu_);
  if (state_.load() != RTM::COMPONENT_ERROR) return;
  if (activity_) activity_->stop();
  {
    std::lock_guard error_lock(error_mu_);
    error_.clear();
  }
  state_.store(RTM::COMPONENT_OFF);
  log().info("{}: reset to COMPONENT_OFF", component_->name());
}

ActivityStats ComponentServant::activity_stats() const {
  const Activity* source = activity_ ? activity_.get() : timing_source_.load();
  return source != nullptr ? source->stats() : ActivityStats{};
}

RTM::TimingStats ComponentServant::timing() {
  RTM::TimingStats out{};
  const ActivityStats s = activity_stats();
  out.period_ns = static_cast<CORBA::ULongLong>(s.period_ns);
  out.cycles = s.cycles;
  out.overruns = s.overruns;
  out.lateness_p50_ns = static_cast<CORBA::ULongLong>(s.lateness_p50_ns);
  out.lateness_p99_ns = static_cast<CORBA::ULongLong>(s.lateness_p99_ns);
  out.lateness_max_ns = static_cast<CORBA::ULongLong>(s.lateness_max_ns);
  out.mean_period_error_ns = s.mean_period_error_ns;
  return out;
}

RTM::ContractStatus ComponentServant::contract() {
  RTM::ContractStatus out{};
  const TimingContract& c = contract_;
  const ActivityStats timing = activity_stats();
  // Unwatched, the contract is what the activity runs: its period and nothing promised.
  out.contract.period_ns = static_cast<CORBA::ULongLong>(watched_ ? c.period_ns : timing.period_ns);
  out.contract.phased = watched_ && c.phase_ns.has_value();
  out.contract.phase_ns = static_cast<CORBA::ULongLong>(out.contract.phased ? *c.phase_ns : 0);
  out.contract.deadline_ns = static_cast<CORBA::ULongLong>(watched_ ? c.effective_deadline_ns() : timing.period_ns);
  out.contract.budget_ns = static_cast<CORBA::ULongLong>(watched_ ? c.budget_ns : 0);
  out.contract.await_ns = static_cast<CORBA::ULongLong>(watched_ ? c.await_ns : await_bound_ns_);
  out.contract.cpu = watched_ ? c.cpu : -1;
  out.contract.sched = c.sched == SchedClass::fifo       ? RTM::SCHED_CLASS_FIFO
                       : c.sched == SchedClass::deadline ? RTM::SCHED_CLASS_DEADLINE
                                                         : RTM::SCHED_CLASS_OTHER;
  out.contract.fifo_priority = c.fifo_priority;
  out.contract.runtime_ns = static_cast<CORBA::ULongLong>(c.sched == SchedClass::deadline ? c.effective_runtime_ns() : 0);
  out.contract.on_miss = c.on_miss == MissAction::brake  ? RTM::MISS_BRAKE
                         : c.on_miss == MissAction::warn ? RTM::MISS_WARN
                                                         : RTM::MISS_COUNT;
  out.watched = watched_;
  if (!watched_) return out;
  const CycleWatchStats s = watch_.stats();
  out.cycles = s.cycles;
  out.over_budget = s.over_budget;
  // A release the schedule skipped after an overrun never ran: its deadline was missed too.
  out.missed_deadline = s.missed_deadline + timing.skipped;
  out.cycle_p50_ns = static_cast<CORBA::ULongLong>(s.cycle_p50_ns);
  out.cycle_p99_ns = static_cast<CORBA::ULongLong>(s.cycle_p99_ns);
  out.cycle_max_ns = static_cast<CORBA::ULongLong>(s.cycle_max_ns);
  out.cycle_max_at_ns = s.cycle_max_at_ns;
  out.response_p50_ns = static_cast<CORBA::ULongLong>(s.response_p50_ns);
  out.response_p99_ns = static_cast<CORBA::ULongLong>(s.response_p99_ns);
  out.response_max_ns = static_cast<CORBA::ULongLong>(s.response_max_ns);
  out.response_max_at_ns = s.response_max_at_ns;
  return out;
}

char* ComponentServant::description() { return CORBA::string_dup(component_->description().c_str()); }

RTM::NameList* ComponentServant::members() {
  const auto& names = component_->member_names();
  auto* out = new RTM::NameList;
  out->length(static_cast<CORBA::ULong>(names.size()));
  for (CORBA::ULong i = 0; i < out->length(); ++i) (*out)[i] = names[i].c_str();
  return out;
}

RTM::StatisticList* ComponentServant::statistics() {
  const auto& stats = component_->statistics();
  auto* out = new RTM::StatisticList;
  out->length(static_cast<CORBA::ULong>(stats.size()));
  for (CORBA::ULong i = 0; i < out->length(); ++i) {
    (*out)[i].name = stats[i].name.c_str();
    (*out)[i].value = stats[i].read();
    (*out)[i].unit = stats[i].unit.c_str();
    (*out)[i].description = stats[i].description.c_str();
  }
  return out;
}

namespace {
RTM::ParameterAccess to_idl(ParameterAccess access) {
  switch (access) {
    case ParameterAccess::fixed: return RTM::PARAMETER_FIXED;
    case ParameterAccess::when_off: return RTM::PARAMETER_WHEN_OFF;
    case ParameterAccess::live: return RTM::PARAMETER_LIVE;
  }
  return RTM::PARAMETER_FIXED;
}
}  // namespace

RTM::ParameterList* ComponentServant::parameters() {
  const auto& params = component_->parameters();
  auto* out = new RTM::ParameterList;
  out->length(static_cast<CORBA::ULong>(params.size()));
  std::lock_guard lock(control_mu_);  // a when-off value is not read while set() writes it
  for (CORBA::ULong i = 0; i < out->length(); ++i) {
    (*out)[i].name = params[i].name.c_str();
    (*out)[i].value = params[i].get().c_str();
    (*out)[i].unit = params[i].unit.c_str();
    (*out)[i].description = params[i].description.c_str();
    (*out)[i].access = to_idl(params[i].access);
  }
  return out;
}

void ComponentServant::set_parameter(const char* name, const char* value) {
  const std::string& me = component_->name();
  auto refuse = [&](const std::string& why) {
    log().warn("{}: set_parameter {} = '{}' refused: {}", me, name, value, why);
    throw RTM::ParameterRefused(why.c_str());
  };
  const auto& params = component_->parameters();
  const auto it = std::find_if(params.begin(), params.end(), [&](const Parameter& p) { return p.name == name; });
  if (it == params.end()) {
    std::string known;
    for (const auto& p : params) known += (known.empty() ? "" : ", ") + p.name;
    refuse(fmt::format("no parameter '{}' (parameters: {})", name, known.empty() ? "none" : known));
  }
  std::lock_guard lock(control_mu_);  // no on()/off() in between: a when-off check holds
  if (it->access == ParameterAccess::fixed)
    refuse(fmt::format("'{}' is fixed while the component runs: give it on the command line", name));
  if (it->access == ParameterAccess::when_off && state_.load() == RTM::COMPONENT_ON)
    refuse(fmt::format("'{}' can change only while {} is off (`rtm off {}` first)", name, me, me));
  std::string before = it->get();
  try {
    it->set(value);
  } catch (const std::exception& e) {
    refuse(e.what());  // it names the parameter, and the value where it helps
  }
  log().info("{}: parameter {} = {} (was {})", me, name, it->get(), before);
}

}  // namespace rtm
