// SPDX-License-Identifier: Apache-2.0
#include "browser/json.h"

#include "rtm/data.h"
#include "rtm/naming.h"

namespace rtm::cli {

using nlohmann::json;

bool name_follows_rule(std::string_view name) {
  try {
    rtm::check_name(name);
    return true;
  } catch (const std::invalid_argument&) {
    return false;
  }
}

std::string failure_text(const CORBA::Exception& e) {
  if (const auto* refused = dynamic_cast<const CORBA::NO_PERMISSION*>(&e);
      refused && (refused->minor() == rtm::kAccessRefusedMinor || refused->minor() == rtm::kCallerUnknownMinor))
    return rtm::access_refusal_text(refused->minor());
  const char* n = e._name();
  return n ? n : "CORBA exception";
}

json timing_json(const RTM::TimingStats& t) {
  return {{"cycles", t.cycles},
          {"overruns", t.overruns},
          {"lateness_p50_ns", t.lateness_p50_ns},
          {"lateness_p99_ns", t.lateness_p99_ns},
          {"lateness_max_ns", t.lateness_max_ns},
          {"mean_period_error_ns", t.mean_period_error_ns}};
}

const char* miss_action_text(RTM::MissAction action) {
  return action == RTM::MISS_BRAKE ? "brake" : action == RTM::MISS_WARN ? "warn" : "count";
}

json contract_json(const RTM::ContractStatus& s) {
  const RTM::TimingContract& c = s.contract;
  const char* sched = c.sched == RTM::SCHED_CLASS_FIFO ? "fifo" : c.sched == RTM::SCHED_CLASS_DEADLINE ? "deadline" : "other";
  json j{{"period_ns", c.period_ns},
         {"phase_ns", c.phased ? json(c.phase_ns) : json(nullptr)},
         {"deadline_ns", c.deadline_ns},
         {"budget_ns", c.budget_ns},
         {"await_ns", c.await_ns},
         {"cpu", c.cpu},
         {"sched", sched},
         {"fifo_priority", c.fifo_priority},
         {"runtime_ns", c.runtime_ns},
         {"on_miss", miss_action_text(c.on_miss)},
         {"watched", s.watched}};
  if (!s.watched) return j;
  j["cycles"] = s.cycles;
  j["over_budget"] = s.over_budget;
  j["missed_deadline"] = s.missed_deadline;
  j["deadline_met"] = s.missed_deadline == 0;
  j["budget_met"] = c.budget_ns == 0 ? json(nullptr) : json(s.over_budget == 0);
  j["cycle_ns"] = {{"p50", s.cycle_p50_ns}, {"p99", s.cycle_p99_ns}, {"max", s.cycle_max_ns}, {"max_at_ns", s.cycle_max_at_ns}};
  j["response_ns"] = {
      {"p50", s.response_p50_ns}, {"p99", s.response_p99_ns}, {"max", s.response_max_ns}, {"max_at_ns", s.response_max_at_ns}};
  return j;
}

json port_json(const PortInfo& p) {
  json j{{"name", p.name}, {"direction", to_string(p.direction)}, {"index", p.index}, {"type", p.type}};
  if (!p.description.empty()) j["description"] = p.description;
  if (!p.elements.empty()) {
    j["elements"] = json::array();
    for (const auto& e : p.elements) j["elements"].push_back({{"name", e.name}, {"unit", e.unit}});
  }
  if (p.extended) {
    j["counters"] = {{"accepted", p.counters.accepted}, {"rejected", p.counters.rejected},
                     {"dropped", p.counters.dropped},   {"pushed", p.counters.pushed},
                     {"failed", p.counters.failed}};
    if (!p.last_error.empty()) j["last_error"] = p.last_error;
  }
  if (p.direction == Direction::out) {
    j["subscriptions"] = json::array();
    for (const auto& s : p.subscriptions) {
      j["subscriptions"].push_back({{"peer", s.peer}, {"type", s.req_type}, {"in_process", s.in_process},
                                    {"path", s.path}, {"kind", s.kind}, {"policy", s.policy}, {"reader", s.reader},
                                    {"pushed", s.pushed}, {"dropped", s.dropped}, {"failures", s.failures},
                                    {"last_failure", s.last_failure}});
    }
  }
  return j;
}

json component_json(const ComponentInfo& c, bool detailed) {
  json j{{"host", c.path.host},
         {"name", c.path.name},
         {"name_ok", name_follows_rule(c.path.name) && name_follows_rule(c.path.host)},
         {"alive", c.liveness == Liveness::alive}};
  if (c.liveness == Liveness::out_of_reach || c.liveness == Liveness::not_member) {
    j["alive"] = nullptr;  // not known from here
    j["unreachable"] = c.liveness == Liveness::out_of_reach ? std::string(kOutOfReachText) : c.dead_reason;
    if (c.liveness == Liveness::not_member) j["not_member"] = true;
    return j;
  }
  if (c.liveness == Liveness::dead) {
    j["dead_reason"] = c.dead_reason;
    return j;
  }
  j["kind"] = c.kind;
  if (!c.description.empty()) j["description"] = c.description;
  j["state"] = c.state;
  if (!c.last_error.empty()) j["last_error"] = c.last_error;
  if (!c.members.empty()) j["members"] = c.members;
  if (c.timing) {
    j["period_ns"] = c.timing->period_ns;
    if (detailed) j["timing"] = timing_json(*c.timing);
  }
  if (c.contract) j["contract"] = contract_json(*c.contract);  // asked for beyond Detail::brief
  j["ports"] = json::array();
  for (const auto& p : c.ports) j["ports"].push_back(port_json(p));
  if (detailed && c.extended) {
    // By name, so a script reads j["statistics"]["watchdog_events"]["value"].
    j["statistics"] = json::object();
    for (const auto& s : c.statistics)
      j["statistics"][s.name] = {{"value", s.value}, {"unit", s.unit}, {"description", s.description}};
    j["parameters"] = json::object();
    for (const auto& p : c.parameters) {
      j["parameters"][p.name] = {
          {"value", p.value}, {"unit", p.unit}, {"description", p.description}, {"access", p.access}};
    }
  }
  return j;
}

}  // namespace rtm::cli
