// SPDX-License-Identifier: Apache-2.0
// Timing contracts, and the analysis that says before start whether a system can keep them:
// what each component promises about when it runs (period, phase, deadline, execution budget,
// CPU, scheduling class) and what a chain of components promises end to end (latency from a
// sample to the last cycle that acts on it, and the age of the data that cycle may act on).
// Pure functions of the contracts and the machine's limits: no CORBA, no clock, no robot.
// docs/timing.md gives the model, the analysis and where it is only a bound.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace rtm {

// ============================ contracts ===============================

enum class SchedClass {
  other,     // SCHED_OTHER: the kernel gives no bound; the analysis gives none either
  fifo,      // SCHED_FIFO at fifo_priority: fixed-priority response-time analysis
  deadline,  // SCHED_DEADLINE: a reservation of runtime_ns every period_ns, due deadline_ns after release
};

// "other", "fifo", "deadline".
const char* sched_class_name(SchedClass sched);

// What a component does when a cycle runs past its budget or ends past its deadline.
enum class MissAction {
  count,  // counts it (rtm ls -l, rtm cat)
  warn,   // counts it, and its process logs a warning (from a thread off the real-time path)
  brake,  // counts it and goes to COMPONENT_ERROR: on_stop() (an actuator commands zero)
};
inline const char* miss_action_name(MissAction action) {
  switch (action) {
    case MissAction::count: return "count";
    case MissAction::warn: return "warn";
    case MissAction::brake: return "brake";
  }
  return "count";
}
// miss_action_name() read back; nullopt for any other text.
inline std::optional<MissAction> parse_miss_action(std::string_view text) {
  for (MissAction action : {MissAction::count, MissAction::warn, MissAction::brake})
    if (text == miss_action_name(action)) return action;
  return std::nullopt;
}

// What one component promises about its periodic cycle. All times in ns, CLOCK_MONOTONIC.
struct TimingContract {
  std::string component;                 // the component's name
  std::int64_t period_ns = 2'000'000;    // > 0
  std::optional<std::int64_t> phase_ns;  // released at k * period_ns + phase_ns; unset: no fixed phase
  std::int64_t deadline_ns = 0;          // each cycle ends within this of its release; 0: the period
  std::int64_t budget_ns = 0;            // the longest one cycle takes, wake to end; 0: not declared
  std::int64_t await_ns = 0;             // it first waits up to this long after release for a datum (--await)
  std::string await_port;                // the InPort it awaits; "" when it names none
  int cpu = -1;                          // pinned to this CPU; -1: any CPU
  SchedClass sched = SchedClass::other;
  int fifo_priority = 0;                 // sched == fifo: 1..99
  std::int64_t runtime_ns = 0;           // sched == deadline: the reservation per period; 0: the budget
  MissAction on_miss = MissAction::count;

  std::int64_t effective_deadline_ns() const { return deadline_ns > 0 ? deadline_ns : period_ns; }
  std::int64_t effective_runtime_ns() const { return runtime_ns > 0 ? runtime_ns : budget_ns; }
};

// What a chain of components promises end to end. A datum's origin is the sample the chain's
// head took in the cycle that wrote it; every component of the path passes it on.
struct ChainContract {
  std::string name;  // the one name rule: lower-case letters, digits, '_'
  // The head's OutPort ("sensor0.wrench"), then each component the data pass through, in order
  // ("controller0", "actuator0"): at least the head and one component. A component may be named
  // with the InPort the data enter it by ("controller0.wrench"): when that is the port it
  // awaits, its wait is bounded by how late its writer can be, not by the await's bound.
  std::vector<std::string> path;
  std::int64_t deadline_ns = 0;  // latency: sample -> end of the last component's first cycle using it; 0: none
  std::int64_t max_age_ns = 0;   // age: sample -> end of any cycle of the last component acting on it; 0: none
  MissAction on_miss = MissAction::count;  // what the chain's end does when it measures a miss
};

// ============================ the machine =============================

struct MachineLimits {
  int cpus = 1;           // CPUs the system may use (0 .. cpus-1)
  double rt_share = 0.95; // share of each CPU SCHED_FIFO and SCHED_DEADLINE may take (kernel's RT throttling)
};

// This machine: the CPUs this process may run on, and /proc/sys/kernel/sched_rt_runtime_us /
// sched_rt_period_us (1.0 when throttling is off, -1).
MachineLimits machine_limits();

// ============================ the analysis ============================

// One thing the analysis found: a refusal means the system cannot keep a contract (rtm up
// refuses it without --force); a warning means a contract cannot be checked (no bound exists).
struct TimingFinding {
  enum class Severity { refusal, warning };
  Severity severity = Severity::refusal;
  std::string subject;  // "controller0", "CPU 1", "chain wrist_to_drive"
  std::string text;     // one sentence with the numbers, e.g. "response bound 2.31 ms > deadline 2 ms"
};

// Load of one CPU: the pinned components' budgets over their periods.
struct CpuLoad {
  int cpu = 0;
  double utilisation = 0;     // every class
  double rt_utilisation = 0;  // SCHED_FIFO and SCHED_DEADLINE only
  struct Share {
    std::string component;
    double utilisation = 0;
  };
  std::vector<Share> shares;  // in the contracts' order
};

// The longest a component's cycle can take from its release to its end.
struct ResponseBound {
  std::string component;
  std::optional<std::int64_t> response_ns;  // none: not bounded (SCHED_OTHER, no budget, or R > deadline)
  std::string how;  // how it was found, or why there is none, in words with the numbers
};

// One hop of a chain: from the writer's release to the release of the reader's cycle that
// reads the datum.
struct HopBound {
  std::string writer, reader;  // component names
  std::int64_t latency_ns = 0;  // to the first reader cycle that reads it
  std::int64_t age_ns = 0;      // to the last reader cycle that may still read it
  std::string how;              // e.g. "same 2 ms grid, phases 0 -> 0.1 ms, writer ends within 0.08 ms"
};

struct ChainBound {
  std::string name;
  std::vector<HopBound> hops;               // empty when some component has no bound
  std::optional<std::int64_t> latency_ns;   // sum of the hops' latency + the last component's response
  std::optional<std::int64_t> age_ns;       // sum of the hops' age + the last component's response
  std::int64_t last_response_ns = 0;        // the last component's response on this chain
  std::string how;                          // why there is no bound, when there is none
};

struct TimingAnalysis {
  std::vector<CpuLoad> cpus;          // CPUs with at least one pinned component, ascending
  double unpinned_utilisation = 0;    // components on any CPU
  std::vector<ResponseBound> responses;  // in the contracts' order
  std::vector<ChainBound> chains;        // in the chains' order
  std::vector<TimingFinding> findings;   // refusals and warnings, in the order found

  bool refused() const;  // some finding is a refusal
  // The whole analysis as text for `rtm check`: per CPU, per component, each chain hop by
  // hop, then the findings.
  std::string explain() const;
};

// Analyses contracts on machine. Never throws for contracts that do not hold: each problem is a
// finding (a malformed contract too: a phase not below the period, a deadline above it, a
// budget above the deadline, a CPU the machine lacks, a FIFO priority out of 1..99, a pinned
// SCHED_DEADLINE component, a chain naming a component without a contract).
TimingAnalysis analyse_timing(const std::vector<TimingContract>& components, const std::vector<ChainContract>& chains,
                              const MachineLimits& machine);

// "2 ms", "150 us", "850 ns", "1.25 ms": a duration for people.
std::string format_duration(std::int64_t ns);

}  // namespace rtm
