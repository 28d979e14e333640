// SPDX-License-Identifier: Apache-2.0
// Components: Component holds the logic (ports + per-cycle function), testable without an
// ORB; ComponentServant makes it an RT component (RTM::RtComponentEx) and owns its activity.
#pragma once

#include "RTMExt.hh"
#include "rt/activity.h"
#include "rt/contract.h"
#include "rt/cycle_watch.h"
#include "rt/histogram.h"
#include "rt/live_value.h"
#include "rtm/describe.h"
#include "rtm/inport.h"
#include "rtm/outport.h"
#include "rtm/parameters.h"

#include <atomic>
#include <memory>
#include <mutex>
#include <string>
#include <variant>
#include <vector>

namespace rtm {

class Orb;

// ============================ Component ===============================

// The logic of a component. A derived class declares its ports (named for what they carry,
// described element by element), its statistics and parameters in its constructor and
// computes in on_cycle(); it never knows which activity calls it. Port N is also reachable as
// in<N> / out<N>.
//
//   class Gain final : public rtm::Component {
//    public:
//     Gain() : Component("gain0", "controller") {
//       add_counters(counters_);
//     }
//     void on_cycle(const rtm::CycleContext&) override {
//       if (in_.read(datum_) == rtm::ReadResult::NewData) {
//         out_.write(scaled(datum_));
//         counters_.scaled.add();
//       }
//     }
//    private:
//     rtm::InPort<RTM::TimedFloat6>& in_ = add_in_port<RTM::TimedFloat6>("wrench", {"wrench to scale", {}});
//     rtm::OutPort<RTM::TimedFloat6>& out_ = add_out_port<RTM::TimedFloat6>("scaled", {"the wrench scaled", {}});
//     RTM::TimedFloat6 datum_{};
//     struct Counters : rtm::CounterSet {
//       rtm::Counter scaled{*this, "scaled", "data scaled"};
//     } counters_;
//   };
class Component {
 public:
  Component(std::string name, std::string kind);
  virtual ~Component();  // closes the out ports (joins their delivery threads)
  Component(const Component&) = delete;
  Component& operator=(const Component&) = delete;

  const std::string& name() const { return name_; }
  const std::string& kind() const { return kind_; }
  // One line saying what the component does ("" until set; the runner sets its --help line).
  const std::string& description() const { return description_; }
  // Adds, for every OutPort made so far, how long write() held the activity
  // (<port>.write_p50 / _p99 / _max, us), the data write() delivered itself (<port>.by_writer)
  // and the calls that outlived their bound (<port>.timed_out) to the statistics. The runner
  // calls it once the component is built; std::invalid_argument when called twice.
  void add_out_port_statistics();
  // Adds "pid": the process the component runs in (`rtm up` checks that a name it waits for is
  // bound to the process it started). The runner calls it.
  void add_process_statistic();
  void set_description(std::string text) { description_ = std::move(text); }
  // A composite's members, by name in its diagram's order; none for other components.
  const std::vector<std::string>& member_names() const { return member_names_; }

  // Called by the activity: on_start() before the first cycle, on_stop() after the last.
  // An exception from any of them puts the component's servant in COMPONENT_ERROR.
  virtual void on_start() {}
  virtual void on_cycle(const CycleContext& ctx) = 0;
  virtual void on_stop() {}

  // Ports in declaration order.
  const std::vector<InPortBase*>& in_ports() const { return in_ptrs_; }
  const std::vector<OutPortBase*>& out_ports() const { return out_ptrs_; }
  // Named figures and parameters in declaration order (see rtm/describe.h).
  const std::vector<Statistic>& statistics() const { return statistics_; }
  const std::vector<Parameter>& parameters() const { return parameters_; }

 protected:
  // The port lives as long as the component (longer while an OutPort still delivers to it).
  template <PortData T>
  InPort<T>& add_in_port(const std::string& port_name, InPortPolicy policy = InPortPolicy::latest()) {
    auto* port = new InPort<T>(port_name, name_, std::move(policy));
    in_ports_.emplace_back(port);
    in_ptrs_.push_back(port);
    return *port;
  }
  template <PortData T>
  OutPort<T>& add_out_port(const std::string& port_name, OutPortOptions options = {}) {
    auto* port = new OutPort<T>(port_name, name_, options);
    out_ports_.emplace_back(port);
    out_ptrs_.push_back(port);
    return *port;
  }
  // The same, described: info says what the port carries (std::invalid_argument when its
  // elements do not match the datum).
  template <PortData T>
  InPort<T>& add_in_port(const std::string& port_name, PortInfo info, InPortPolicy policy = InPortPolicy::latest()) {
    auto& port = add_in_port<T>(port_name, std::move(policy));
    port.set_info(std::move(info));
    return port;
  }
  template <PortData T>
  OutPort<T>& add_out_port(const std::string& port_name, PortInfo info, OutPortOptions options = {}) {
    auto& port = add_out_port<T>(port_name, options);
    port.set_info(std::move(info));
    return port;
  }
  // A composite names its members once, when it is made.
  void set_member_names(std::vector<std::string> names) { member_names_ = std::move(names); }
  // read() is called from ORB threads while the component runs. Throws std::invalid_argument
  // for an empty or repeated name or a missing read().
  void add_statistic(std::string stat_name, std::string unit, std::string text, std::function<double()> read);
  // Each counter of set (rtm/describe.h) as a statistic without a unit; set must outlive the
  // component's servant.
  void add_counters(const CounterSet& set);
  // <stat>_p50, <stat>_p99 and <stat>_max of h, in us, described as "<span>, median" etc. h
  // must outlive the component's servant.
  void add_percentile_statistics(const std::string& stat, const std::string& span, const LatencyHistogram& h);
  // Throws std::invalid_argument for an empty or repeated name, a missing get(), or a
  // writable parameter without set().
  void add_parameter(Parameter parameter);
  // Each parameter of table (rtm/parameters.h), kept in value: `rtm cat` shows
  // value.published(), `rtm set` checks the text as the table says and publishes the whole
  // struct changed (ComponentServant serialises the sets), the cycle take()s it. table and
  // value must outlive the component's servant.
  template <class P>
  void add_parameters(const ParameterTable<P>& table, LiveValue<P>& value) {
    for (const auto& entry : table.entries()) {
      const auto* decl = &entry;
      add_parameter({.name = decl->name,
                     .unit = decl->unit,
                     .description = decl->description,
                     .access = decl->access,
                     .get = [decl, &value] { return decl->get(value.published()); },
                     .set = [decl, &value](std::string_view text) {
                       P changed = value.published();
                       decl->set(changed, text, "");  // the refusal names the component
                       value.publish(changed);
                     }});
    }
  }

 private:
  friend class ComponentServant;  // adds the statistics of what it does around the cycle
  const std::string name_;
  const std::string kind_;
  std::string description_;
  std::vector<std::string> member_names_;
  std::vector<Statistic> statistics_;
  std::vector<Parameter> parameters_;
  std::vector<PortableServer::Servant_var<InPortBase>> in_ports_;
  std::vector<PortableServer::Servant_var<OutPortBase>> out_ports_;
  std::vector<InPortBase*> in_ptrs_;
  std::vector<OutPortBase*> out_ptrs_;
};

// ============================ ComponentServant ========================

// Which activity runs a component's cycle.
struct OnArrival {
  std::size_t in_port_index = 0;  // the InPort whose arrivals trigger a cycle
};
struct ExternalTick {};  // driven by someone else's SharedTick through cycle_function()
using ActivitySpec = std::variant<PeriodicOptions, OnArrival, ExternalTick>;

// Keeps the holds of composites on a component (RtComponentEx::hold/release): the host's
// (host/lease.h: each hold renewed within its lease, else the component turns itself off).
class HoldKeeper {
 public:
  virtual ~HoldKeeper() = default;
  // Starts or renews holder's hold; std::invalid_argument for a lease it does not take.
  virtual void hold(const std::string& holder, std::uint32_t lease_ms) = 0;
  virtual void release(const std::string& holder) = 0;
};

// An RT component: the RtComponentEx servant around a Component, owning its activity.
//
// on() (COMPONENT_OFF -> COMPONENT_ON) calls on_start() and starts the activity; off() stops
// it, waits for the thread to end, calls on_stop(). Both are idempotent and safe from any
// thread. A cycle (or on_start/on_stop) that throws moves the component to COMPONENT_ERROR:
// the activity stops, last_error() says why, on() raises BAD_INV_ORDER(kMinorComponentError)
// until reset().
class ComponentServant : public virtual POA_RTM::RtComponentEx {
 public:
  // Throws std::invalid_argument when OnArrival names a port that does not exist.
  ComponentServant(std::unique_ptr<Component> component, ActivitySpec activity = PeriodicOptions{});
  ~ComponentServant() override;  // off(), deactivate()

  // Activates itself and every port in orb's POA; returns the component's reference.
  RTM::RtComponentEx_ptr activate(Orb& orb);
  void deactivate();  // idempotent; ports too
  RTM::RtComponentEx_ptr reference() const;  // nil before activate(); caller owns it

  Component& component() { return *component_; }
  const Component& component() const { return *component_; }
  RTM::ComponentState current_state() const { return state_.load(); }
  std::string error_text() const;

  // For ExternalTick: the function a SharedTick calls each period. It runs one cycle when the
  // component is ON, does nothing when OFF, and returns false once it is in COMPONENT_ERROR.
  CycleFunction cycle_function();
  // Timing reported by timing() for an ExternalTick component (e.g. the composite's tick).
  void set_timing_source(const Activity* activity);

  // A periodic component's cycle first waits for a new datum on port (one of its InPorts),
  // at most until bound_ns after the cycle was due (InPortBase::wait_new_until): on a phase
  // just after its writer's, a writer a little late then delays this cycle by that much
  // instead of leaving it a period behind. Counted in the statistics await.arrived (the datum
  // came while it waited) and await.missed (it did not come within the bound; the cycle runs
  // with what the port holds). Before on(); bound_ns > 0.
  void await_before_cycle(InPortBase& port, std::int64_t bound_ns);

  // Watches each cycle against contract (rt/contract.h, docs/timing.md): how long it ran
  // (from its start, after any await or, on a shared tick, after the members before it, to its
  // end) against the budget, and when it ended against
  // the deadline after its release; the figures are statistics (cycle_time_p50/_p99/_max,
  // response_p50/_p99/_max, over_budget, missed_deadline) and contract(). MissAction::brake puts
  // the component in COMPONENT_ERROR at the first miss (its on_stop() runs); warn is the host's
  // to log. Before on(); a second call changes the contract, the statistics stay.
  void watch_contract(const TimingContract& contract);
  // The contract watched; nullptr when none is.
  const TimingContract* timing_contract() const { return watched_ ? &contract_ : nullptr; }
  CycleWatchStats contract_stats() const { return watch_.stats(); }

  // The end of a chain (docs/timing.md): after each cycle, how old the data of port (a Stamped
  // type's: the stamp of the sample it derives from, which each component on the way passes on)
  // are at the cycle's end, on CLOCK_REALTIME. The first cycle that reads a datum gives its
  // latency, held to deadline_ns; every cycle gives the age of what the port last gave, held to
  // max_age_ns (0: not held). Statistics chain.<name>.latency_p50/_p99/_max and .age_p99/_max
  // (us), .late and .stale (counts). Before on(); std::invalid_argument for a port whose datum
  // carries no stamp, or a name watched twice.
  struct ChainWatch {
    std::string name;
    InPortBase* port = nullptr;
    std::int64_t deadline_ns = 0;
    std::int64_t max_age_ns = 0;
    MissAction on_miss = MissAction::count;  // brake: COMPONENT_ERROR at the first late or stale cycle
  };
  void watch_chain(ChainWatch watch);
  // Each watched chain's misses so far (a host's warner reads them).
  struct ChainStatus {
    std::string name;
    MissAction on_miss;
    std::uint64_t late, stale;
    std::int64_t latency_max_ns, age_max_ns;
  };
  std::vector<ChainStatus> chain_status() const;

  // Re-simulation (rtm/cycle_tap.h): `observer` is told when the component starts, before each
  // cycle and when it stops. Before on(); null to stop. The observer outlives its use.
  void observe_cycles(CycleObserver* observer) { observer_ = observer; }

  // Who keeps composites' holds; before activate(). Without one, hold() raises NO_IMPLEMENT.
  void keep_holds(std::unique_ptr<HoldKeeper> keeper) { holds_ = std::move(keeper); }

  // A composite hands out another component's InPort as its own: in_ports()[index] becomes
  // ref (index == size appends). Throws std::out_of_range otherwise.
  void expose_in_port(std::size_t index, RTM::InPort_ptr ref);

  // ---- IDL ----
  void on() override;
  void off() override;
  RTM::InPortList* in_ports() override;
  RTM::OutPortList* out_ports() override;
  char* name() override;
  char* kind() override;
  RTM::ComponentState state() override;
  char* last_error() override;
  void reset() override;
  RTM::TimingStats timing() override;
  char* description() override;
  RTM::StatisticList* statistics() override;
  RTM::ParameterList* parameters() override;
  // Refuses (RTM::ParameterRefused, nothing changed) an unknown name, a fixed parameter, a
  // when-off parameter while ON, and a value the parameter's set() rejects. Logs each change.
  void set_parameter(const char* name, const char* value) override;
  // A composite's hold (RTMExt.idl), kept by keep_holds()'s keeper: BAD_PARAM for a lease it
  // does not take, NO_IMPLEMENT when there is none.
  void hold(const char* holder, CORBA::ULong lease_ms) override;
  void release(const char* holder) override;
  RTM::NameList* members() override;
  RTM::ContractStatus contract() override;

 private:
  bool run_cycle(const CycleContext& ctx);
  // The timing of the activity that runs it (its own, or set_timing_source()'s); zero without one.
  ActivityStats activity_stats() const;
  void fail(const std::string& why);

  std::unique_ptr<Component> component_;
  ActivitySpec spec_;
  std::unique_ptr<Activity> activity_;
  std::atomic<const Activity*> timing_source_{nullptr};
  std::shared_ptr<ArrivalSignal> arrival_;
  CycleObserver* observer_ = nullptr;
  InPortBase* await_port_ = nullptr;  // await_before_cycle()
  std::int64_t await_bound_ns_ = 0;
  struct AwaitCounters : CounterSet {
    Counter arrived{*this, "await.arrived", "cycles whose awaited datum came while they waited for it"};
    Counter missed{*this, "await.missed", "cycles whose awaited datum did not come within the bound"};
  } await_counters_;
  struct WatchedChain {
    ChainWatch watch;
    LatencyHistogram latency;
    LatencyHistogram age;
    std::atomic<std::uint64_t> late{0};
    std::atomic<std::uint64_t> stale{0};
    std::uint64_t seen = 0;  // the port's stamps_taken() at the last cycle
  };
  // After a cycle: the chains' and the contract's figures; why a brake stops it ("": none does).
  std::string record_chains(std::uint64_t cycle);
  std::string record_contract(const CycleContext& ctx, std::int64_t start_ns);
  std::vector<std::unique_ptr<WatchedChain>> chains_;  // watch_chain(); fixed once on()
  TimingContract contract_;  // watch_contract()
  bool watched_ = false;
  CycleWatch watch_;
  std::mutex control_mu_;  // serialises on/off/reset
  std::atomic<RTM::ComponentState> state_{RTM::COMPONENT_OFF};
  mutable std::mutex error_mu_;
  std::string error_;
  Orb* orb_ = nullptr;
  mutable std::mutex refs_mu_;  // guards ref_, in_overrides_
  RTM::RtComponentEx_var ref_;
  std::vector<RTM::InPort_var> in_overrides_;  // non-nil: handed out instead of our own port
  std::unique_ptr<HoldKeeper> holds_;  // reset first in the destructor: no off() from it after
};

}  // namespace rtm
