// SPDX-License-Identifier: Apache-2.0
#include "host/ticked_composite.h"

#include "rtm/inport.h"
#include "rtm/outport.h"

#include <fmt/format.h>
#include <spdlog/logger.h>

#include <stdexcept>

namespace rtm {

std::int64_t phased_first_deadline(std::int64_t reference_ns, std::int64_t lead_ns, std::int64_t period_ns) {
  if (lead_ns < 0 || lead_ns >= period_ns)
    throw std::invalid_argument("tick lead " + std::to_string(lead_ns) + " ns: want 0 <= lead < the period (" +
                                std::to_string(period_ns) + " ns)");
  if (reference_ns <= 0) return 0;
  // A reference earlier than one lead after the clock's origin: its previous cycle's lead point.
  return reference_ns > lead_ns ? reference_ns - lead_ns : reference_ns - lead_ns + period_ns;
}

TickedComposite::TickedComposite(std::string name, std::string kind, Diagram diagram,
                                 std::vector<std::unique_ptr<Component>> members, PeriodicOptions tick,
                                 TickPhase phase, TickStage* stage)
    : Component(std::move(name), std::move(kind)),
      diagram_(std::move(diagram)),
      tick_(std::move(tick)),
      phase_(std::move(phase)),
      stage_(stage) {
  if (!diagram_.ticked) throw std::invalid_argument(this->name() + ": diagram " + diagram_.name + " is not ticked");
  diagram_.check_structure();
  std::vector<std::string> names;
  for (const auto& c : members) {
    if (!c) throw std::invalid_argument(this->name() + ": a member is missing");
    names.push_back(c->name());
  }
  std::vector<std::unique_ptr<Component>> ordered;
  std::vector<const Component*> view;
  for (const std::size_t i : diagram_.arrange(names, this->name())) {
    ordered.push_back(std::move(members[i]));
    view.push_back(ordered.back().get());
  }
  diagram_.check(catalogue_of(view));
  std::vector<std::string> in_order;
  for (const auto* c : view) in_order.push_back(c->name());
  set_member_names(std::move(in_order));
  if (stage_ && phase_.next_reference_deadline_ns)
    throw std::invalid_argument(this->name() + ": a tick that runs its stage cannot also be phased against it");
  phased_first_deadline(0, phase_.lead_ns, tick_.options().period_ns);  // validates the lead
  for (auto& c : ordered) {
    owned_.emplace_back(new ComponentServant(std::move(c), ExternalTick{}));
    servants_.push_back(owned_.back().in());
    servants_.back()->set_timing_source(&tick_);
  }
  add_stage_and_members();
}

void TickedComposite::add_stage_and_members() {
  // A failed member must not stop the tick by itself (see the header).
  auto keep_going = [](CycleFunction f) {
    return [f = std::move(f)](const CycleContext& ctx) {
      f(ctx);
      return true;
    };
  };
  if (stage_) {
    add_counters(counters_);
    tick_.add([this](const CycleContext& ctx) {
      if (stage_cycle_is_mine(ctx) && !stage_->receive(ctx.deadline_ns)) stage_lost_.store(true);
      return true;
    });
  }
  for (auto* member : servants_) tick_.add(keep_going(member->cycle_function()));
  if (stage_) {
    tick_.add([this](const CycleContext& ctx) {
      if (!stage_cycle_is_mine(ctx)) return true;
      if (stage_->transmit(ctx.deadline_ns))
        last_transmit_deadline_ns_.store(ctx.deadline_ns, std::memory_order_relaxed);
      else
        stage_lost_.store(true);
      return true;
    });
  }
}

CycleFunction TickedComposite::handing_back_on_stop(CycleFunction cycle) {
  return [this, cycle = std::move(cycle)](const CycleContext& ctx) {
    if (cycle(ctx)) return true;
    hand_back_stage(ctx.deadline_ns + ctx.period_ns);
    return false;
  };
}

void TickedComposite::hand_back_stage(std::int64_t next_deadline_ns) {
  if (stage_taken_.exchange(false)) stage_->hand_back(next_deadline_ns);
}

TickedComposite::~TickedComposite() {
  tick_.stop();
  hand_back_stage(0);
  for (auto* member : servants_) {
    try {
      member->off();
    } catch (...) {
    }
    member->deactivate();
  }
  servants_.clear();
  while (!owned_.empty()) owned_.erase(owned_.begin());  // the diagram's order
}

void TickedComposite::activate_members(Orb& orb) {
  for (auto* member : servants_) RTM::RtComponentEx_var ref = member->activate(orb);
}

ComponentServant& TickedComposite::member(std::string_view name) const {
  for (auto* s : servants_) {
    if (s->component().name() == name) return *s;
  }
  throw std::invalid_argument(fmt::format("{}: no member {}", this->name(), name));
}

RTM::InPort_ptr TickedComposite::in_port(const PortRef& port) const {
  InPortBase* in = in_port_of(member(port.member).component(), port.port);
  if (!in) throw std::invalid_argument(fmt::format("{}: {} has no InPort {}", name(), port.member, port.port));
  RTM::InPortEx_var ref = in->reference();
  if (CORBA::is_nil(ref)) throw std::logic_error(name() + ": members not activated");
  return RTM::InPort::_duplicate(ref.in());
}

std::string TickedComposite::connect_members() {
  disconnect_members();  // a connection left from an earlier run is replaced
  for (const auto& c : diagram_.connections) {
    auto* out = out_port_of(member(c.from.member).component(), c.from.port);
    auto* in = in_port_of(member(c.to.member).component(), c.to.port);
    if (!out || !in) return c.text() + ": no such port";  // the constructor's check makes this unreachable
    if (!out->connect_local(*in, c.policy)) return c.text() + ": " + out->last_error_text();
  }
  return "";
}

void TickedComposite::disconnect_members() {
  for (const auto& c : diagram_.connections) {
    auto* out = out_port_of(member(c.from.member).component(), c.from.port);
    auto* in = in_port_of(member(c.to.member).component(), c.to.port);
    if (out && in) out->disconnect_local(*in);
  }
}

void TickedComposite::turn_members_off() {
  for (auto it = servants_.rbegin(); it != servants_.rend(); ++it) (*it)->off();
}

void TickedComposite::on_start() {
  if (const std::string why = connect_members(); !why.empty()) {
    disconnect_members();
    throw std::runtime_error(name() + ": connecting the members failed: " + why);
  }
  try {
    for (auto it = servants_.rbegin(); it != servants_.rend(); ++it) (*it)->on();
  } catch (const CORBA::Exception&) {
    turn_members_off();
    std::string why;
    for (auto* member : servants_) {
      if (member->current_state() == RTM::COMPONENT_ERROR)
        why += " " + member->component().name() + ": " + member->error_text();
    }
    throw std::runtime_error(name() + ": turning the members on failed:" + why);
  }
  std::int64_t first_ns = 0;
  if (stage_) {
    first_ns = stage_->take_over();  // the stage's own cycles stop before its next deadline
    stage_taken_.store(true);
    stage_lost_.store(false);
    stage_resume_ns_.store(0, std::memory_order_relaxed);
    last_transmit_deadline_ns_.store(0, std::memory_order_relaxed);
  } else if (phase_.next_reference_deadline_ns) {
    first_ns = phased_first_deadline(phase_.next_reference_deadline_ns(), phase_.lead_ns, tick_.options().period_ns);
  }
  tick_.set_first_deadline_ns(first_ns);
  try {
    tick_.start();
  } catch (...) {
    hand_back_stage(first_ns);
    throw;
  }
  std::string order;
  for (const auto& m : diagram_.members) order += (order.empty() ? "" : " -> ") + m.name;
  if (stage_)
    log().info("{}: shared tick running its stage's cycle: receive, {}, transmit", name(), order);
  else if (first_ns != 0)
    log().info("{}: shared tick running {}, {} us before each reference cycle", name(), order, phase_.lead_ns / 1000);
  else
    log().info("{}: shared tick running {}", name(), order);
}

void TickedComposite::on_cycle(const CycleContext&) {
  if (stage_lost_.load()) retake_stage();
  for (auto* member : servants_) {
    if (member->current_state() == RTM::COMPONENT_ERROR)
      throw std::runtime_error("member " + member->component().name() + " failed: " + member->error_text());
  }
}

// The stage (the bus master: its watchdog) took the cycles back: this tick ran none for
// several periods while the stage's own thread woke on time (this thread's CPU stalled, or
// higher-priority work held the tick off). The stage's thread runs them meanwhile, on this
// tick's grid (the bus master holds the drives at zero: FaultKind::cycle_owner_lost, which the
// actuator resets as a command loss). The tick is running again, so it takes them again:
// take_over() waits for the stage's cycle in progress and returns the first deadline that
// thread did not run; the stage halves of the tick's cycles before it are skipped, so no
// period carries two SYNCs.
void TickedComposite::retake_stage() {
  const std::int64_t resume_ns = stage_->take_over();
  stage_resume_ns_.store(resume_ns, std::memory_order_relaxed);
  stage_lost_.store(false);
  const std::uint64_t event = counters_.stage_retakes.add();
  log().warn("{}: the stage had taken its cycles back (this tick ran none for too long): running them again from "
             "the next deadline (retake {})",
             name(), event);
}

void TickedComposite::on_stop() {
  tick_.stop();
  // Joined (or, from the tick's own thread, its last cycle has run): the stage's thread takes
  // the cycles back on the tick's grid, before the members' off() (an actuator's waits for
  // its zero command to leave).
  const std::int64_t last_ns = last_transmit_deadline_ns_.load(std::memory_order_relaxed);
  hand_back_stage(last_ns > 0 ? last_ns + tick_.options().period_ns : 0);
  turn_members_off();
  disconnect_members();
  log().info("{}: members off", name());
}

}  // namespace rtm
