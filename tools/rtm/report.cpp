// SPDX-License-Identifier: Apache-2.0
#include "report.h"

#include <fmt/chrono.h>
#include <fmt/format.h>

#include <cmath>
#include <ctime>

namespace rtm::cli {

namespace {

std::string us(unsigned long long ns) { return fmt::format("{:.1f}", ns / 1000.0); }

std::string short_type(const std::string& type) {
  return type.rfind("RTM::", 0) == 0 ? type.substr(5) : type;
}

std::string period_text(const ComponentInfo& c) {
  if (!c.timing || c.timing->period_ns == 0) return "-";
  return fmt::format("{:g} ms", c.timing->period_ns / 1e6);
}

// A duration as the contract states it: "2 ms", "80 us".
std::string duration_text(unsigned long long ns) {
  return ns >= 1'000'000 ? fmt::format("{:g} ms", ns / 1e6) : fmt::format("{:g} us", ns / 1e3);
}

// The local time of a CLOCK_REALTIME stamp, "16:41:02"; "" for none.
std::string when_text(long long realtime_ns) {
  if (realtime_ns <= 0) return "";
  return fmt::format(" at {:%H:%M:%S}", fmt::localtime(static_cast<std::time_t>(realtime_ns / 1'000'000'000)));
}

// "contract: deadline 2 ms met (response p99 85.0 us, max 310.0 us at 16:41:02); budget 80 us:
// 3 over (cycle p99 40.0 us, max 95.0 us at 16:40:58); fifo 80 on CPU 1, on miss: warn", or ""
// for a component that is not watched.
std::string contract_text(const RTM::ContractStatus& s) {
  if (!s.watched) return "";
  const RTM::TimingContract& c = s.contract;
  std::string text = fmt::format("contract: deadline {} {} (response p99 {} us, max {} us{})", duration_text(c.deadline_ns),
                                 s.missed_deadline == 0 ? std::string("met") : fmt::format("MISSED {}×", s.missed_deadline),
                                 us(s.response_p99_ns), us(s.response_max_ns), when_text(s.response_max_at_ns));
  const std::string cycle =
      fmt::format("cycle p99 {} us, max {} us{}", us(s.cycle_p99_ns), us(s.cycle_max_ns), when_text(s.cycle_max_at_ns));
  text += c.budget_ns == 0 ? fmt::format("; no budget ({})", cycle)
                           : fmt::format("; budget {} {} ({})", duration_text(c.budget_ns),
                                         s.over_budget == 0 ? std::string("met") : fmt::format("EXCEEDED {}×", s.over_budget), cycle);
  const std::string sched = c.sched == RTM::SCHED_CLASS_FIFO       ? fmt::format("fifo {}", c.fifo_priority)
                            : c.sched == RTM::SCHED_CLASS_DEADLINE ? fmt::format("deadline {} reserved", duration_text(c.runtime_ns))
                                                                   : std::string("other");
  text += fmt::format("; {}{}, on miss: {}", sched, c.cpu >= 0 ? fmt::format(" on CPU {}", c.cpu) : std::string(),
                      miss_action_text(c.on_miss));
  return text;
}

// "fx fy fz tx ty tz [N N N N·m N·m N·m]", or "" when the port does not say.
std::string elements_text(const std::vector<ElementInfo>& elements) {
  if (elements.empty()) return "";
  std::string names, units;
  bool any_unit = false;
  for (const auto& e : elements) {
    names += (names.empty() ? "" : " ") + e.name;
    units += (units.empty() ? "" : " ") + (e.unit.empty() ? std::string("-") : e.unit);
    any_unit = any_unit || !e.unit.empty();
  }
  return any_unit ? fmt::format("{} [{}]", names, units) : names;
}


void print_port(const PortInfo& p) {
  std::string counters;
  if (p.extended && p.direction == Direction::in) {
    counters = fmt::format("accepted {}  rejected {}  dropped {}", p.counters.accepted, p.counters.rejected,
                           p.counters.dropped);
  } else if (p.extended) {
    counters = fmt::format("written {}  pushed {}  dropped {}  failed {}", p.counters.accepted, p.counters.pushed,
                           p.counters.dropped, p.counters.failed);
  }
  fmt::print("  {:<6} {:<14} {:<20} {}\n", fmt::format("{}{}", to_string(p.direction), p.index),
             terminal_text(p.name), terminal_text(p.type), counters);
  if (!p.description.empty()) fmt::print("        {}\n", terminal_text(p.description));
  if (const auto elements = elements_text(p.elements); !elements.empty())
    fmt::print("        {}\n", terminal_text(elements));
  if (!p.last_error.empty()) fmt::print("        last error: {}\n", terminal_text(p.last_error));
  for (const auto& s : p.subscriptions) {
    fmt::print("        -> {} ({}, {})  pushed {}  dropped {}{}\n", terminal_text(s.peer), s.req_type,
               terminal_text(s.path), s.pushed, s.dropped,
               s.failures ? fmt::format("  failing x{}{}", s.failures,
                                        s.last_failure.empty() ? "" : ": " + terminal_text(s.last_failure))
                          : "");
    if (!s.policy.empty())
      fmt::print("           {}: {}{}\n", terminal_text(s.kind), terminal_text(s.policy),
                 s.reader.empty() ? "" : "; the InPort keeps " + terminal_text(s.reader));
  }
}

void print_statistics_and_parameters(const ComponentInfo& c) {
  if (!c.statistics.empty()) fmt::print("  statistics\n");
  for (const auto& s : c.statistics) {
    const std::string value = s.unit.empty() ? format_statistic(s.value) : format_statistic(s.value) + " " + s.unit;
    fmt::print("    {:<24} {:>14}  {}\n", terminal_text(s.name), terminal_text(value), terminal_text(s.description));
  }
  if (!c.parameters.empty()) fmt::print("  parameters\n");
  for (const auto& p : c.parameters) {
    fmt::print("    {:<24} {}{}  ({}; {})\n", terminal_text(p.name), terminal_text(p.value),
               p.unit.empty() ? "" : " [" + terminal_text(p.unit) + "]", terminal_text(p.access),
               terminal_text(p.description));
  }
}

}  // namespace

std::string terminal_text(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  const auto escape = [&](unsigned char byte) { out += fmt::format("\\x{:02x}", byte); };
  for (std::size_t i = 0; i < text.size();) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c < 0x80) {
      if (c == '\\') out += "\\\\";
      else if (c == '\n') out += "\\n";
      else if (c == '\t') out += "\\t";
      else if (c < 0x20 || c == 0x7f) escape(c);
      else out += static_cast<char>(c);
      ++i;
      continue;
    }
    // A UTF-8 sequence: its length from the lead byte, each continuation 10xxxxxx, no overlong
    // form, no surrogate, nothing above U+10FFFF, and no C1 control (U+0080..U+009F: a
    // terminal takes U+009B as CSI) nor line or paragraph separator.
    const std::size_t length = c >= 0xf0 && c <= 0xf4 ? 4 : c >= 0xe0 ? 3 : c >= 0xc2 && c < 0xe0 ? 2 : 0;
    char32_t code = length == 4 ? c & 0x07u : length == 3 ? c & 0x0fu : c & 0x1fu;
    bool valid = length > 0 && i + length <= text.size() && !(length == 3 && c > 0xef);
    for (std::size_t k = 1; valid && k < length; ++k) {
      const auto next = static_cast<unsigned char>(text[i + k]);
      valid = (next & 0xc0) == 0x80;
      code = (code << 6) | (next & 0x3fu);
    }
    const char32_t smallest = length == 4 ? 0x10000 : length == 3 ? 0x800 : 0x80;
    valid = valid && code >= smallest && code <= 0x10ffff && !(code >= 0xd800 && code <= 0xdfff) &&
            !(code >= 0x80 && code <= 0x9f) && code != 0x2028 && code != 0x2029;
    if (!valid) {
      escape(c);
      ++i;
      continue;
    }
    out.append(text.substr(i, length));
    i += length;
  }
  return out;
}

std::string shown_name(std::string_view name) {
  return name_follows_rule(name) ? std::string(name) : terminal_text(name) + " (not a valid name)";
}

std::string format_statistic(double value) {
  if (std::isfinite(value) && value == std::floor(value) && std::fabs(value) < 1e15) return fmt::format("{:.0f}", value);
  return fmt::format("{:.3f}", value);
}

void print_ls(const std::vector<ComponentInfo>& comps, bool detailed) {
  std::string host;
  for (const auto& c : comps) {
    if (c.path.host != host) {
      host = c.path.host;
      fmt::print("{}\n", shown_name(host));
    }
    const std::string name = shown_name(c.path.name);
    if (c.liveness == Liveness::dead) {
      fmt::print("  {:<16} dead ({}): process gone; `rtm ls --clean` removes it\n", name, terminal_text(c.dead_reason));
      continue;
    }
    if (c.liveness == Liveness::out_of_reach || c.liveness == Liveness::not_member) {
      fmt::print("  {:<16} {}\n", name,
                 c.liveness == Liveness::out_of_reach ? std::string(kOutOfReachText) : terminal_text(c.dead_reason));
      continue;
    }
    std::string ins, outs;
    for (const auto& p : c.ports) {
      auto& s = p.direction == Direction::in ? ins : outs;
      s += fmt::format("{}{}:{}", s.empty() ? "" : " ", terminal_text(p.name), terminal_text(short_type(p.type)));
    }
    fmt::print("  {:<16} {:<5} {:<11} {:<8} in[{}] out[{}]\n", name, c.state,
               c.kind.empty() ? "-" : terminal_text(c.kind), period_text(c), ins, outs);
    if (detailed && c.timing) {
      const auto& t = *c.timing;
      fmt::print("  {:<16} lateness p50 {} us  p99 {} us  max {} us  overruns {} of {} cycles\n", "",
                 us(t.lateness_p50_ns), us(t.lateness_p99_ns), us(t.lateness_max_ns), t.overruns, t.cycles);
    }
    if (detailed && c.contract && c.contract->watched) fmt::print("  {:<16} {}\n", "", contract_text(*c.contract));
    if (!detailed) continue;
    // Its wiring: each subscription of its OutPorts, with its kind and connection policy.
    for (const auto& p : c.ports)
      for (const auto& s : p.subscriptions)
        fmt::print("  {:<16} {} -> {}  {}: {}\n", "", terminal_text(p.name), terminal_text(s.peer),
                   terminal_text(s.kind.empty() ? s.path : s.kind), terminal_text(s.policy.empty() ? s.req_type : s.policy));
  }
  if (comps.empty()) fmt::print("(no components)\n");
}

void print_cat(const ComponentInfo& c) {
  fmt::print("{}.host_cxt/{}.rtc  kind {}  state {}  period {}\n", shown_name(c.path.host), shown_name(c.path.name),
             c.kind.empty() ? "-" : terminal_text(c.kind), c.state, period_text(c));
  if (!c.description.empty()) fmt::print("  {}\n", terminal_text(c.description));
  if (!c.last_error.empty()) fmt::print("  error: {}\n", terminal_text(c.last_error));
  if (!c.members.empty()) {
    std::string names;
    for (const auto& m : c.members) {
      if (!names.empty()) names += ' ';
      names += terminal_text(m);
    }
    fmt::print("  members: {}\n", names);
  }
  if (c.timing) {
    const auto& t = *c.timing;
    fmt::print("  lateness p50 {} us  p99 {} us  max {} us  overruns {} of {} cycles\n", us(t.lateness_p50_ns),
               us(t.lateness_p99_ns), us(t.lateness_max_ns), t.overruns, t.cycles);
  }
  if (c.contract && c.contract->watched) fmt::print("  {}\n", contract_text(*c.contract));
  for (const auto& p : c.ports) print_port(p);
  print_statistics_and_parameters(c);
}

}  // namespace rtm::cli
