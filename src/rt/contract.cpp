// SPDX-License-Identifier: Apache-2.0
#include "rt/contract.h"

#include <sched.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <thread>

namespace rtm {

const char* sched_class_name(SchedClass sched) {
  switch (sched) {
    case SchedClass::other:
      return "other";
    case SchedClass::fifo:
      return "fifo";
    case SchedClass::deadline:
      return "deadline";
  }
  return "other";
}

// ============================ the machine =============================

namespace {

std::optional<long long> read_proc_number(const char* path) {
  std::ifstream in(path);
  long long value = 0;
  if (!(in >> value)) return std::nullopt;
  return value;
}

}  // namespace

MachineLimits machine_limits() {
  MachineLimits m;
  cpu_set_t set;
  CPU_ZERO(&set);
  if (::sched_getaffinity(0, sizeof set, &set) == 0)
    m.cpus = CPU_COUNT(&set);
  else
    m.cpus = static_cast<int>(std::thread::hardware_concurrency());
  if (m.cpus < 1) m.cpus = 1;
  const auto runtime_us = read_proc_number("/proc/sys/kernel/sched_rt_runtime_us");
  const auto period_us = read_proc_number("/proc/sys/kernel/sched_rt_period_us");
  if (runtime_us && *runtime_us == -1)
    m.rt_share = 1.0;  // throttling off
  else if (runtime_us && period_us && *runtime_us >= 0 && *period_us > 0)
    m.rt_share = std::min(1.0, static_cast<double>(*runtime_us) / static_cast<double>(*period_us));
  else
    m.rt_share = 0.95;  // the kernel's default
  return m;
}

// ============================ words for people ========================

std::string format_duration(std::int64_t ns) {
  if (ns == 0) return "0";
  const std::string sign = ns < 0 ? "-" : "";
  // Unsigned, so that the most negative value has a magnitude too.
  const std::uint64_t magnitude = ns < 0 ? 0 - static_cast<std::uint64_t>(ns) : static_cast<std::uint64_t>(ns);
  if (magnitude < 1'000) return sign + std::to_string(magnitude) + " ns";
  const bool ms = magnitude >= 1'000'000;
  const std::uint64_t step_ns = ms ? 1'000 : 1;                           // one thousandth of the unit
  const std::uint64_t thousandths = (magnitude + step_ns / 2) / step_ns;  // rounded half up
  std::string text = sign + std::to_string(thousandths / 1'000);
  if (const std::uint64_t fraction = thousandths % 1'000; fraction != 0) {
    char digits[8];
    std::snprintf(digits, sizeof digits, "%03u", static_cast<unsigned>(fraction));
    std::string decimals = digits;
    while (decimals.back() == '0') decimals.pop_back();
    text += "." + decimals;
  }
  return text + (ms ? " ms" : " us");
}

namespace {

std::string fd(std::int64_t ns) { return format_duration(ns); }

std::string two_decimals(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.2f", value);
  return text;
}

std::string cpus_text(int cpus) { return std::to_string(cpus) + (cpus == 1 ? " CPU" : " CPUs"); }

std::string cpu_text(int cpu) { return cpu < 0 ? "any CPU" : "CPU " + std::to_string(cpu); }

std::string join(const std::vector<std::string>& parts, const char* separator) {
  std::string out;
  for (const auto& part : parts) {
    if (!out.empty()) out += separator;
    out += part;
  }
  return out;
}

// Sums of doubles: shares of 0.1 + 0.2 + 0.7 must not come out above 1.
constexpr double kShareSlack = 1e-9;

// Absurd periods must saturate, not wrap around into small bounds.
std::int64_t add_sat(std::int64_t a, std::int64_t b) {
  std::int64_t sum = 0;
  return __builtin_add_overflow(a, b, &sum) ? std::numeric_limits<std::int64_t>::max() : sum;
}
std::int64_t mul_sat(std::int64_t a, std::int64_t b) {
  std::int64_t product = 0;
  return __builtin_mul_overflow(a, b, &product) ? std::numeric_limits<std::int64_t>::max() : product;
}
std::int64_t ceil_div(std::int64_t a, std::int64_t b) { return a / b + (a % b != 0 ? 1 : 0); }  // a >= 0, b > 0

bool is_rt(const TimingContract& c) { return c.sched == SchedClass::fifo || c.sched == SchedClass::deadline; }

// The share of a CPU a component takes: its budget, or for SCHED_DEADLINE its reservation (what
// the kernel sets aside for it, whether used or not).
double share_of(const TimingContract& c) {
  const std::int64_t work = c.sched == SchedClass::deadline ? c.effective_runtime_ns() : c.budget_ns;
  return static_cast<double>(work) / static_cast<double>(c.period_ns);
}

bool name_rule(const std::string& name) {
  return !name.empty() && std::all_of(name.begin(), name.end(), [](char ch) {
    return (ch >= 'a' && ch <= 'z') || (ch >= '0' && ch <= '9') || ch == '_';
  });
}

// ============================ validation ==============================

std::vector<std::string> contract_problems(const TimingContract& c, const MachineLimits& machine) {
  std::vector<std::string> p;
  const std::int64_t T = c.period_ns;
  if (T <= 0) return {"period " + fd(T) + " is not above 0"};  // nothing else means anything without one
  if (c.phase_ns && (*c.phase_ns < 0 || *c.phase_ns >= T))
    p.push_back("phase " + fd(*c.phase_ns) + " is not within [0, the period " + fd(T) + ")");
  if (c.deadline_ns < 0)
    p.push_back("deadline " + fd(c.deadline_ns) + " is negative");
  else if (c.deadline_ns > T)
    p.push_back("deadline " + fd(c.deadline_ns) + " above the period " + fd(T) +
                ": cycles of one activity never overlap");
  const std::int64_t D = c.effective_deadline_ns();
  if (c.budget_ns < 0)
    p.push_back("budget " + fd(c.budget_ns) + " is negative");
  else if (c.budget_ns > D)
    p.push_back("budget " + fd(c.budget_ns) + " above the deadline " + fd(D));
  if (c.await_ns < 0)
    p.push_back("await " + fd(c.await_ns) + " is negative");
  else if (c.await_ns >= D)
    p.push_back("await " + fd(c.await_ns) + " not below the deadline " + fd(D) + ": no time would be left to run");
  if (c.cpu < -1 || c.cpu >= machine.cpus)
    p.push_back("CPU " + std::to_string(c.cpu) + " is not on this machine, which has " + cpus_text(machine.cpus) +
                " (-1: any)");
  if (c.sched == SchedClass::fifo) {
    if (c.fifo_priority < 1 || c.fifo_priority > 99)
      p.push_back("SCHED_FIFO priority " + std::to_string(c.fifo_priority) + " is outside 1..99");
  } else if (c.fifo_priority != 0) {
    p.push_back("priority " + std::to_string(c.fifo_priority) + " with class " + sched_class_name(c.sched) +
                ": only SCHED_FIFO takes one");
  }
  if (c.sched == SchedClass::deadline) {
    if (c.cpu >= 0)
      p.push_back("pinned to CPU " + std::to_string(c.cpu) +
                  ": the kernel refuses SCHED_DEADLINE for a thread pinned to one CPU; leave cpu unset");
    const std::int64_t runtime = c.effective_runtime_ns();
    if (c.runtime_ns < 0)
      p.push_back("runtime " + fd(c.runtime_ns) + " is negative");
    else if (runtime <= 0)
      p.push_back("SCHED_DEADLINE without a runtime: set runtime_ns or the budget");
    else if (runtime > D)
      p.push_back("runtime " + fd(runtime) + " above the deadline " + fd(D) + ": the kernel refuses the reservation");
    else if (c.budget_ns > runtime)
      p.push_back("budget " + fd(c.budget_ns) + " above its reservation " + fd(runtime));
    // The activity gives the kernel its period as the reservation's deadline: a constrained one
    // (below the period) is throttled at a wake-up on the activity's own grid until the kernel's
    // next period, which drifts from that grid (docs/performance.md: p50 lateness 150-450 us).
    if (D < T)
      p.push_back("deadline " + fd(D) + " below the period " + fd(T) +
                  " with SCHED_DEADLINE: its reservation is due at the end of the period (a shorter one is "
                  "throttled off the activity's grid); use SCHED_FIFO for a deadline below the period");
  }
  return p;
}

// ============================ response times ==========================

// One interferer's part of a bound: count jobs of cost each.
struct Term {
  std::size_t component = 0;
  std::int64_t count = 0, cost_ns = 0, jitter_ns = 0, period_ns = 0;
  // On one grid with k (same period, both phased): j's releases relative to k's ((phase_j -
  // phase_k) mod T) and its response. Then only the jobs of j whose window [release, release +
  // response) overlaps k's [0, R) count, instead of ceil((R + J) / T).
  std::optional<std::int64_t> offset_ns;
  std::int64_t response_ns = 0;
  bool queued_behind = false;  // j's jobs released after k's are queued behind k: equal priority, k never sleeps
};

// Jobs of j released at offset + m * period (m any integer) whose window [release, release +
// response_j) overlaps [from, to): responses are at most a period, so no job before m = -1.
// Only jobs released at or before latest_release count: an equal-priority job released after k
// is queued behind it (SCHED_FIFO), unless k sleeps meanwhile.
std::int64_t overlapping_jobs(std::int64_t offset, std::int64_t response_j, std::int64_t period, std::int64_t from,
                              std::int64_t to, std::int64_t latest_release = std::numeric_limits<std::int64_t>::max()) {
  std::int64_t jobs = 0;
  for (std::int64_t release = offset - period; release < to && release <= latest_release;
       release = add_sat(release, period)) {
    if (add_sat(release, response_j) > from) ++jobs;
    if (jobs > 1'000'000) break;  // a bound this far past its periods is refused anyway
  }
  return jobs;
}

// Whether j may preempt k: on a CPU k may run on, SCHED_DEADLINE, or SCHED_FIFO at k's priority
// or above (an equal-priority job already running runs to its end).
bool may_preempt(const TimingContract& j, const TimingContract& k) {
  if (!(j.cpu == k.cpu || j.cpu < 0 || k.cpu < 0)) return false;
  return j.sched == SchedClass::deadline || (j.sched == SchedClass::fifo && j.fifo_priority >= k.fifo_priority);
}

// j at k's own SCHED_FIFO priority while k never sleeps in its cycle: a job of j released after
// k's is queued behind it.
bool same_queue(const TimingContract& j, const TimingContract& k) {
  return j.sched == SchedClass::fifo && k.sched == SchedClass::fifo && j.fifo_priority == k.fifo_priority &&
         k.await_ns == 0;
}

// On one grid with k: j's releases after k's, (phase_j - phase_k) mod T; none otherwise.
std::optional<std::int64_t> grid_offset(const TimingContract& j, const TimingContract& k) {
  if (j.sched != SchedClass::fifo || !j.phase_ns || !k.phase_ns || j.period_ns != k.period_ns) return std::nullopt;
  std::int64_t offset = (*j.phase_ns - *k.phase_ns) % k.period_ns;
  return offset < 0 ? offset + k.period_ns : offset;
}

struct Iteration {
  std::int64_t response_ns = 0;
  bool above_deadline = false;  // response_ns is the first iterate above the deadline
  std::vector<Term> terms;
};

// R = a + C + sum over hp of ceil((R + J) / T) * C, from R = a + C until it settles or passes D.
Iteration iterate(std::int64_t await_ns, std::int64_t budget_ns, std::int64_t deadline_ns, std::vector<Term> hp) {
  const std::int64_t own = add_sat(await_ns, budget_ns);
  std::int64_t r = own;
  for (;;) {
    std::int64_t next = own;
    for (auto& t : hp) {
      t.count = t.offset_ns ? overlapping_jobs(*t.offset_ns, t.response_ns, t.period_ns, 0, r,
                                               t.queued_behind ? 0 : std::numeric_limits<std::int64_t>::max())
                            : ceil_div(add_sat(r, t.jitter_ns), t.period_ns);
      next = add_sat(next, mul_sat(t.count, t.cost_ns));
    }
    if (next > deadline_ns) return {next, true, std::move(hp)};
    if (next == r) return {r, false, std::move(hp)};
    r = next;
  }
}

struct Response {
  std::optional<std::int64_t> response_ns;
  std::string how;
  std::optional<TimingFinding> finding;  // found while bounding it
};

class ResponseAnalysis {
 public:
  ResponseAnalysis(const std::vector<TimingContract>& c, const std::vector<bool>& valid) : c_(c), valid_(valid) {}

  std::vector<Response> run() {
    out_.assign(c_.size(), {});
    std::vector<std::size_t> fifo;
    for (std::size_t k = 0; k < c_.size(); ++k) {
      if (!valid_[k]) continue;
      const TimingContract& ck = c_[k];
      if (ck.sched == SchedClass::other) {
        out_[k].how = "SCHED_OTHER: the kernel gives no bound";
      } else if (ck.budget_ns == 0) {
        out_[k].how = "no budget declared";
        out_[k].finding = TimingFinding{TimingFinding::Severity::warning, ck.component,
                                        "no budget declared: its response cannot be bounded"};
      } else if (ck.sched == SchedClass::deadline) {
        bound_deadline(k);
      } else {
        fifo.push_back(k);
      }
    }
    bound_fifo(fifo);
    return std::move(out_);
  }

 private:
  // Admitted, a reservation gets its runtime before its deadline, which the activity sets at the
  // end of the period (validation refuses a shorter one). An await breaks that: the kernel judges
  // the wake-up after it as a new arrival and starts a new period then (deadline = wake + T).
  void bound_deadline(std::size_t k) {
    const TimingContract& ck = c_[k];
    const std::int64_t T = ck.period_ns, D = ck.effective_deadline_ns(), Q = ck.effective_runtime_ns();
    const std::int64_t a = ck.await_ns;
    Response& r = out_[k];
    if (a == 0) {
      r.response_ns = D;
      r.how = "SCHED_DEADLINE reservation of " + fd(Q) + " every " + fd(T) + " within " + fd(D);
      return;
    }
    const std::string text = "response bound " + fd(add_sat(a, D)) + " > deadline " + fd(D) +
                             ": waking after its await of " + fd(a) +
                             " starts a new reservation period; a component that awaits needs SCHED_FIFO";
    r.how = text;
    r.finding = TimingFinding{TimingFinding::Severity::refusal, ck.component, text};
  }

  // Components that may preempt k: on a CPU k may run on, SCHED_DEADLINE, or SCHED_FIFO at k's
  // priority or above (an equal-priority job already running runs to its end).
  std::vector<std::size_t> higher_priority(std::size_t k) const {
    std::vector<std::size_t> hp;
    for (std::size_t j = 0; j < c_.size(); ++j) {
      if (j != k && valid_[j] && may_preempt(c_[j], c_[k])) hp.push_back(j);
    }
    return hp;
  }

  // How late in its window j's work may come, as release jitter. A job of a reservation runs
  // anywhere within its deadline. A FIFO job that awaits, or that runs on other CPUs as well, may
  // run its budget at the end of its response (R - C) and the next one at its release: suspension
  // as jitter J = a alone is unsafe once j itself is preempted after its await. Only a job pinned
  // to k's CPU that never awaits has none: it cannot be pending when k's CPU turns to lower work.
  std::int64_t jitter(std::size_t j, std::size_t k, std::int64_t response_j) const {
    const TimingContract& cj = c_[j];
    if (cj.sched == SchedClass::deadline) return cj.effective_deadline_ns();
    if (cj.await_ns == 0 && cj.cpu >= 0 && cj.cpu == c_[k].cpu) return 0;
    return response_j - cj.budget_ns;
  }

  // Jointly for all FIFO components: a jitter depends on the interferer's own bound, and equal
  // priorities depend on each other. Bounds only grow from a + C, so the first fixed point is
  // the least one.
  void bound_fifo(const std::vector<std::size_t>& fifo) {
    enum class State { pending, bounded, none };
    std::vector<State> state(c_.size(), State::pending);
    std::vector<std::int64_t> r(c_.size(), 0);
    std::vector<Iteration> last(c_.size());
    std::vector<std::vector<std::size_t>> hp(c_.size());
    for (std::size_t k : fifo) {
      r[k] = c_[k].await_ns + c_[k].budget_ns;
      hp[k] = higher_priority(k);
      for (std::size_t j : hp[k]) {
        if (c_[j].sched == SchedClass::fifo && c_[j].budget_ns == 0) {
          state[k] = State::none;
          out_[k].how = "no bound: " + c_[j].component + " may preempt it and declares no budget";
          break;
        }
      }
    }
    for (int round = 0; round < 1000; ++round) {
      bool changed = false;
      for (std::size_t k : fifo) {
        if (state[k] == State::none) continue;
        std::vector<Term> terms;
        for (std::size_t j : hp[k]) {
          const TimingContract& cj = c_[j];
          if (cj.sched == SchedClass::fifo && state[j] == State::none) {
            state[k] = State::none;
            out_[k].how = "no bound: " + cj.component + " may preempt it and has no bound itself";
            break;
          }
          const std::int64_t cost = cj.sched == SchedClass::deadline ? cj.effective_runtime_ns() : cj.budget_ns;
          Term term{j, 0, cost, jitter(j, k, r[j]), cj.period_ns, grid_offset(cj, c_[k]), r[j], same_queue(cj, c_[k])};
          terms.push_back(term);
        }
        if (state[k] == State::none) {
          changed = true;
          continue;
        }
        Iteration it = iterate(c_[k].await_ns, c_[k].budget_ns, c_[k].effective_deadline_ns(), std::move(terms));
        if (it.above_deadline) {
          state[k] = State::none;
          last[k] = std::move(it);
          refuse_late(k, last[k]);
          changed = true;
        } else {
          if (state[k] == State::pending || it.response_ns != r[k]) changed = true;
          state[k] = State::bounded;
          r[k] = it.response_ns;
          last[k] = std::move(it);  // the terms with the interferers' latest jitter, for how
        }
      }
      if (!changed) break;
    }
    for (std::size_t k : fifo) {
      if (state[k] == State::bounded) {
        out_[k].response_ns = r[k];
        out_[k].how = describe(k, last[k]);
      } else if (state[k] == State::pending) {
        out_[k].how = "no bound: the analysis did not settle";
      }
    }
  }

  void refuse_late(std::size_t k, const Iteration& it) {
    const TimingContract& ck = c_[k];
    std::vector<std::string> names;
    for (const auto& t : it.terms)
      if (t.count > 0) names.push_back(c_[t.component].component);
    const std::string cause = names.empty() ? describe(k, it) : "interference from " + join(names, ", ");
    const std::string text = "response bound " + fd(it.response_ns) + " > deadline " + fd(ck.effective_deadline_ns()) +
                             " on " + cpu_text(ck.cpu) + " (" + cause + ")";
    out_[k].how = text;
    out_[k].finding = TimingFinding{TimingFinding::Severity::refusal, ck.component, text};
  }

  // "await 0.15 ms + budget 0.05 ms + interference 0.05 ms (sensor0 1×0.05 ms)"
  std::string describe(std::size_t k, const Iteration& it) const {
    const TimingContract& ck = c_[k];
    std::string text = ck.await_ns > 0 ? "await " + fd(ck.await_ns) + " + " : "";
    text += "budget " + fd(ck.budget_ns);
    std::int64_t interference = 0;
    std::vector<std::string> parts;
    for (const auto& t : it.terms) {
      if (t.count == 0) continue;  // on its grid, clear of k's window
      interference = add_sat(interference, mul_sat(t.count, t.cost_ns));
      std::string part = c_[t.component].component + " " + std::to_string(t.count) + "×" + fd(t.cost_ns);
      if (t.offset_ns)
        part += " on its grid " + fd(*t.offset_ns) + " after it";
      else if (t.jitter_ns > 0)
        part += " with jitter " + fd(t.jitter_ns);
      parts.push_back(part);
    }
    if (!parts.empty()) text += " + interference " + fd(interference) + " (" + join(parts, ", ") + ")";
    return text;
  }

  const std::vector<TimingContract>& c_;
  const std::vector<bool>& valid_;
  std::vector<Response> out_;
};

// ============================ chains ==================================

struct ChainContext {
  const std::vector<TimingContract>& contracts;
  const std::map<std::string, std::size_t>& index;  // name -> the first contract of that name
  const std::vector<ResponseBound>& responses;
};

// One component of a chain: its contract, and the InPort the data enter it by ("" when the
// path does not say).
struct ChainNode {
  std::size_t contract = 0;
  std::string entry_port;
};

std::vector<std::string> chain_problems(const ChainContract& chain, const ChainContext& ctx,
                                        std::vector<ChainNode>& nodes) {
  std::vector<std::string> p;
  if (!name_rule(chain.name)) p.push_back("name '" + chain.name + "' is not lower-case letters, digits and '_'");
  if (chain.deadline_ns < 0) p.push_back("deadline " + fd(chain.deadline_ns) + " is negative");
  if (chain.max_age_ns < 0) p.push_back("max age " + fd(chain.max_age_ns) + " is negative");
  if (chain.path.size() < 2)
    p.push_back("the path needs the head's port (component.port) and at least one component after it");
  if (!chain.path.empty()) {
    const std::string& head = chain.path[0];
    const std::size_t dot = head.find('.');
    if (dot == std::string::npos || dot == 0 || dot + 1 == head.size()) {
      p.push_back("the path starts with '" + head + "', not component.port");
    } else if (auto found = ctx.index.find(head.substr(0, dot)); found == ctx.index.end()) {
      p.push_back("'" + head.substr(0, dot) + "' has no contract");
    } else {
      nodes.push_back({found->second, ""});
    }
  }
  for (std::size_t i = 1; i < chain.path.size(); ++i) {
    const std::string& step = chain.path[i];
    const std::size_t dot = step.find('.');
    const std::string name = step.substr(0, dot);
    const std::string port = dot == std::string::npos ? std::string() : step.substr(dot + 1);
    if (dot != std::string::npos && (dot == 0 || port.empty() || port.find('.') != std::string::npos)) {
      p.push_back("'" + step + "' is neither a component nor component.inport");
      continue;
    }
    const auto found = ctx.index.find(name);
    if (found == ctx.index.end()) {
      p.push_back("'" + name + "' has no contract");
      continue;
    }
    const std::string& previous = chain.path[i - 1];
    if (previous.substr(0, previous.find('.')) == name) p.push_back("'" + name + "' twice in a row");
    nodes.push_back({found->second, port});
  }
  return p;
}

// reader_wait_ns: set when the reader awaits the port the chain enters by, on one grid with its
// writer: it waits no longer than the writer can be late past the reader's release.
HopBound hop(const TimingContract& w, const TimingContract& r, std::int64_t writer_response_ns,
             const std::string& entry_port, std::optional<std::int64_t>& reader_wait_ns) {
  HopBound h;
  h.writer = w.component;
  h.reader = r.component;
  const std::int64_t R = writer_response_ns;
  if (w.period_ns == r.period_ns && w.phase_ns && r.phase_ns) {
    // One grid: the reader's cycle released delta after the writer's reads the datum if the
    // writer ends before that cycle stops awaiting; else a later cycle of the grid does.
    const std::int64_t T = w.period_ns;
    std::int64_t delta = *r.phase_ns - *w.phase_ns;
    if (delta < 0) delta += T;
    const std::int64_t ready_by = add_sat(delta, r.await_ns);
    h.latency_ns = R <= ready_by ? delta : add_sat(delta, mul_sat(T, ceil_div(R - ready_by, T)));
    h.age_ns = h.latency_ns;
    h.how = "same " + fd(T) + " grid, phases " + fd(*w.phase_ns) + " -> " + fd(*r.phase_ns) + ", writer ends within " +
            fd(R) + (r.await_ns > 0 ? ", reader awaits " + fd(r.await_ns) : std::string()) + ": " + fd(h.latency_ns);
    if (r.await_ns > 0 && !entry_port.empty() && entry_port == r.await_port && R <= ready_by)
      reader_wait_ns = std::clamp<std::int64_t>(R - delta, 0, r.await_ns);
    return h;
  }
  // No grid: the reader's next release is at most one reader period after the datum; the datum
  // is replaced at most one writer period plus its response after the writer's release.
  h.latency_ns = add_sat(R, r.period_ns);
  h.age_ns = add_sat(w.period_ns, R);
  h.how = "no common grid: writer ends within " + fd(R) + ", reader released every " + fd(r.period_ns) + ": latency " +
          fd(h.latency_ns) + ", age " + fd(h.age_ns);
  return h;
}

// The response of k on a chain where it waits at most wait for its datum: suspended until then,
// it runs its budget from there with the jobs whose windows overlap what is left, R' = wait + C +
// sum of those, from wait + C up. Never above its own bound with the await cut to wait.
std::int64_t response_after_wait(const ChainContext& ctx, std::size_t k, std::int64_t wait) {
  const TimingContract& ck = ctx.contracts[k];
  const std::int64_t standalone = *ctx.responses[k].response_ns - ck.await_ns + wait;
  if (ck.sched != SchedClass::fifo) return standalone;
  const std::int64_t own = add_sat(wait, ck.budget_ns);
  std::int64_t r = own;
  for (int round = 0; round < 1000; ++round) {
    std::int64_t next = own;
    for (std::size_t j = 0; j < ctx.contracts.size(); ++j) {
      const TimingContract& cj = ctx.contracts[j];
      if (j == k || !may_preempt(cj, ck)) continue;
      if (!ctx.responses[j].response_ns) return standalone;  // an interferer without a bound
      const std::int64_t rj = *ctx.responses[j].response_ns;
      const std::int64_t cost = cj.sched == SchedClass::deadline ? cj.effective_runtime_ns() : cj.budget_ns;
      const auto offset = grid_offset(cj, ck);
      // Woken at the end of its wait, k is queued behind the equal-priority jobs released by then.
      const bool equal = cj.sched == SchedClass::fifo && cj.fifo_priority == ck.fifo_priority;
      const std::int64_t jobs =
          offset ? overlapping_jobs(*offset, rj, cj.period_ns, wait, r, equal ? wait : std::numeric_limits<std::int64_t>::max())
                 : ceil_div(add_sat(r, std::max<std::int64_t>(rj - cost, 0)), cj.period_ns);
      next = add_sat(next, mul_sat(jobs, cost));
    }
    if (next >= standalone) return standalone;
    if (next == r) break;
    r = next;
  }
  return r;
}

ChainBound bound_chain(const ChainContract& chain, const ChainContext& ctx, std::vector<TimingFinding>& findings) {
  ChainBound b;
  b.name = chain.name;
  const std::string subject = "chain " + (chain.name.empty() ? std::string("(no name)") : chain.name);
  std::vector<ChainNode> nodes;
  const std::vector<std::string> problems = chain_problems(chain, ctx, nodes);
  if (!problems.empty()) {
    for (const auto& p : problems) findings.push_back({TimingFinding::Severity::refusal, subject, p});
    b.how = "not analysed: " + join(problems, "; ");
    return b;
  }
  for (const ChainNode& n : nodes) {
    const ResponseBound& r = ctx.responses[n.contract];
    if (!r.response_ns) {
      b.how = r.component + " (" + r.how + ")";
      if (chain.deadline_ns > 0 || chain.max_age_ns > 0)
        findings.push_back({TimingFinding::Severity::warning, subject, "cannot be bounded: " + b.how});
      return b;
    }
  }
  std::int64_t latency = 0, age = 0;
  std::int64_t writer_ends = *ctx.responses[nodes.front().contract].response_ns;
  for (std::size_t i = 0; i + 1 < nodes.size(); ++i) {
    const std::size_t reader = nodes[i + 1].contract;
    std::optional<std::int64_t> wait;
    b.hops.push_back(hop(ctx.contracts[nodes[i].contract], ctx.contracts[reader], writer_ends, nodes[i + 1].entry_port, wait));
    std::int64_t reader_ends = *ctx.responses[reader].response_ns;
    if (wait) {
      reader_ends = response_after_wait(ctx, reader, *wait);
      b.hops.back().how += "; it awaits " + ctx.contracts[reader].component + "." + nodes[i + 1].entry_port +
                           ", so waits at most " + fd(*wait) + " and ends within " + fd(reader_ends);
    }
    latency = add_sat(latency, b.hops.back().latency_ns);
    age = add_sat(age, b.hops.back().age_ns);
    writer_ends = reader_ends;
  }
  const std::int64_t last = writer_ends;
  b.last_response_ns = last;
  b.latency_ns = add_sat(latency, last);
  b.age_ns = add_sat(age, last);
  if (chain.deadline_ns > 0 && *b.latency_ns > chain.deadline_ns)
    findings.push_back({TimingFinding::Severity::refusal, subject,
                        "latency bound " + fd(*b.latency_ns) + " > deadline " + fd(chain.deadline_ns)});
  if (chain.max_age_ns > 0 && *b.age_ns > chain.max_age_ns)
    findings.push_back({TimingFinding::Severity::refusal, subject,
                        "age bound " + fd(*b.age_ns) + " > max age " + fd(chain.max_age_ns)});
  return b;
}

// Utilisation, per CPU and in all: a refusal for each limit it passes.
void analyse_load(const std::vector<TimingContract>& components, const std::vector<bool>& valid,
                  const std::map<std::string, std::size_t>& index, const MachineLimits& machine, TimingAnalysis& a) {
  const auto refuse = [&](std::string subject, std::string text) {
    a.findings.push_back({TimingFinding::Severity::refusal, std::move(subject), std::move(text)});
  };
  std::map<int, CpuLoad> loads;
  double total = 0, total_rt = 0, total_deadline = 0;
  for (std::size_t k = 0; k < components.size(); ++k) {
    if (!valid[k]) continue;
    const TimingContract& c = components[k];
    const double u = share_of(c);
    total += u;
    if (is_rt(c)) total_rt += u;
    if (c.sched == SchedClass::deadline) total_deadline += u;
    if (c.cpu < 0) {
      a.unpinned_utilisation += u;
      continue;
    }
    CpuLoad& load = loads[c.cpu];
    load.cpu = c.cpu;
    load.utilisation += u;
    if (is_rt(c)) load.rt_utilisation += u;
    load.shares.push_back({c.component, u});
  }
  for (auto& [cpu, load] : loads) {
    const auto shares = [&](bool rt_only) {
      std::vector<std::string> parts;
      for (const auto& s : load.shares) {
        if (rt_only && !is_rt(components[index.at(s.component)])) continue;
        parts.push_back(s.component + " " + two_decimals(s.utilisation));
      }
      return join(parts, ", ");
    };
    const std::string subject = "CPU " + std::to_string(cpu);
    if (load.utilisation > 1.0 + kShareSlack)
      refuse(subject, "budgets take " + two_decimals(load.utilisation) + " of it (" + shares(false) + ")");
    if (load.rt_utilisation > machine.rt_share + kShareSlack)
      refuse(subject, "SCHED_FIFO and SCHED_DEADLINE budgets take " + two_decimals(load.rt_utilisation) +
                          " of it, above the " + two_decimals(machine.rt_share) + " the kernel leaves them (" +
                          shares(true) + ")");
    a.cpus.push_back(std::move(load));
  }
  const double rt_capacity = machine.cpus * machine.rt_share;
  const std::string all_cpus = "the " + cpus_text(machine.cpus);
  const std::string capacity_text =
      two_decimals(rt_capacity) + " (" + std::to_string(machine.cpus) + " × " + two_decimals(machine.rt_share) + ")";
  if (total_rt > rt_capacity + kShareSlack)
    refuse("all CPUs", "SCHED_FIFO and SCHED_DEADLINE budgets take " + two_decimals(total_rt) + " of " + all_cpus +
                           ", above the " + capacity_text + " the kernel leaves them");
  if (total > machine.cpus + kShareSlack) refuse("all CPUs", "budgets take " + two_decimals(total) + " of " + all_cpus);
  if (total_deadline > rt_capacity + kShareSlack)
    refuse("all CPUs", "SCHED_DEADLINE reservations take " + two_decimals(total_deadline) + ", above the " +
                           capacity_text + " the kernel admits: it would refuse them");
}

}  // namespace

// ============================ the analysis ============================

TimingAnalysis analyse_timing(const std::vector<TimingContract>& components, const std::vector<ChainContract>& chains,
                              const MachineLimits& machine) {
  TimingAnalysis a;
  const auto refuse = [&](std::string subject, std::string text) {
    a.findings.push_back({TimingFinding::Severity::refusal, std::move(subject), std::move(text)});
  };

  // Malformed contracts are refused and left out of the rest.
  std::vector<bool> valid(components.size(), false);
  std::vector<std::string> invalid_how(components.size());
  std::map<std::string, std::size_t> index;
  for (std::size_t k = 0; k < components.size(); ++k) {
    const TimingContract& c = components[k];
    std::vector<std::string> problems = contract_problems(c, machine);
    if (c.component.empty()) problems.insert(problems.begin(), "a component without a name");
    if (!index.emplace(c.component, k).second) problems.insert(problems.begin(), "a component name given twice");
    const std::string subject = c.component.empty() ? "component " + std::to_string(k) : c.component;
    for (const auto& p : problems) refuse(subject, p);
    valid[k] = problems.empty();
    if (!valid[k]) invalid_how[k] = "not analysed: " + join(problems, "; ");
  }

  analyse_load(components, valid, index, machine, a);

  // Response bounds.
  std::vector<Response> responses = ResponseAnalysis(components, valid).run();
  for (std::size_t k = 0; k < components.size(); ++k) {
    ResponseBound r;
    r.component = components[k].component;
    if (!valid[k]) {
      r.how = invalid_how[k];
    } else {
      r.response_ns = responses[k].response_ns;
      r.how = std::move(responses[k].how);
      if (responses[k].finding) a.findings.push_back(std::move(*responses[k].finding));
    }
    a.responses.push_back(std::move(r));
  }

  // Chains.
  const ChainContext ctx{components, index, a.responses};
  for (const auto& chain : chains) a.chains.push_back(bound_chain(chain, ctx, a.findings));
  return a;
}

bool TimingAnalysis::refused() const {
  return std::any_of(findings.begin(), findings.end(),
                     [](const TimingFinding& f) { return f.severity == TimingFinding::Severity::refusal; });
}

std::string TimingAnalysis::explain() const {
  std::ostringstream out;
  for (const auto& load : cpus) {
    out << "CPU " << load.cpu << ": " << two_decimals(load.utilisation) << " of it (rt "
        << two_decimals(load.rt_utilisation) << ")";
    std::vector<std::string> parts;
    for (const auto& s : load.shares) parts.push_back(s.component + " " + two_decimals(s.utilisation));
    if (!parts.empty()) out << ": " << join(parts, ", ");
    out << "\n";
  }
  if (unpinned_utilisation > 0) out << "any CPU: " << two_decimals(unpinned_utilisation) << "\n";
  std::size_t width = 0;
  for (const auto& r : responses) width = std::max(width, r.component.size());
  for (const auto& r : responses) {
    out << r.component << std::string(width - r.component.size() + 2, ' ');
    if (r.response_ns)
      out << "response <= " << fd(*r.response_ns) << " (" << r.how << ")\n";
    else
      out << "no bound (" << r.how << ")\n";
  }
  for (const auto& c : chains) {
    out << "chain " << c.name << ": ";
    if (!c.latency_ns || !c.age_ns || c.hops.empty()) {
      out << "no bound (" << c.how << ")\n";
      continue;
    }
    out << c.hops.front().writer;
    for (const auto& h : c.hops) out << " -> " << h.reader;
    out << ": latency <= " << fd(*c.latency_ns) << ", age <= " << fd(*c.age_ns) << "\n";
    for (const auto& h : c.hops)
      out << "  " << h.writer << " -> " << h.reader << ": latency " << fd(h.latency_ns) << ", age " << fd(h.age_ns)
          << " (" << h.how << ")\n";
    out << "  " << c.hops.back().reader << " ends within " << fd(c.last_response_ns) << "\n";
  }
  for (const auto& f : findings)
    out << (f.severity == TimingFinding::Severity::refusal ? "refused: " : "warning: ") << f.subject << ": " << f.text
        << "\n";
  if (findings.empty()) out << "no findings: every contract can be kept\n";
  return out.str();
}

}  // namespace rtm
