// SPDX-License-Identifier: Apache-2.0
#include "components/servo/servo.h"

#include "rtm/log.h"
#include "rtm/orb.h"

#include <fmt/format.h>
#include <spdlog/logger.h>

#include <stdexcept>
#include <thread>
#include <vector>

namespace rtm::comp {

namespace {

std::string text_of(const CORBA::Exception& e) { return std::string("CORBA ") + e._name(); }

std::string name_of(RTM::RtComponent_ptr component, const char* role) {
  // Only an RTM::RtComponentEx knows its name; a seed RtComponent is named by its role.
  try {
    RTM::RtComponentEx_var ex = RTM::RtComponentEx::_narrow(component);
    if (CORBA::is_nil(ex)) return role;
    CORBA::String_var name = ex->name();
    return name.in();
  } catch (const CORBA::Exception&) {
    return role;
  }
}

// Why an OutPort refused a subscription (an RTM::OutPortEx says it; a plain OutPort cannot).
std::string refusal_of(RTM::OutPort_ptr port) {
  try {
    RTM::OutPortEx_var ex = RTM::OutPortEx::_narrow(port);
    if (!CORBA::is_nil(ex)) {
      CORBA::String_var why = ex->last_error();
      return why.in();
    }
  } catch (const CORBA::Exception& e) {
    return text_of(e);
  }
  return "refused";
}

// The port of a remote component named `port`, or "in<N>"/"out<N>" (a 2004 component whose
// ports say no name of use); nil when it has none. names: each port's name, for a message.
template <class List, class Port>
typename Port::_ptr_type find_port(const List& ports, const std::string& port, const char* prefix,
                                   std::vector<std::string>* names = nullptr) {
  for (CORBA::ULong i = 0; i < ports.length(); ++i) {
    CORBA::String_var n = ports[i]->name();
    if (names) names->push_back(n.in());
    if (port == n.in() || port == prefix + std::to_string(i)) return Port::_duplicate(ports[i]);
  }
  return Port::_nil();
}

RTM::InPort_ptr find_in(RTM::RtComponent_ptr c, const std::string& port, std::vector<std::string>* names = nullptr) {
  RTM::InPortList_var ins = c->in_ports();
  return find_port<RTM::InPortList, RTM::InPort>(ins.in(), port, "in", names);
}

RTM::OutPort_ptr find_out(RTM::RtComponent_ptr c, const std::string& port, std::vector<std::string>* names = nullptr) {
  RTM::OutPortList_var outs = c->out_ports();
  return find_port<RTM::OutPortList, RTM::OutPort>(outs.in(), port, "out", names);
}

// What a remote port is, for a diagram's check: its type, and its elements' units when it
// describes them (an RTMExt port).
template <class Ex, class Port>
rtm::PortShape shape_of(Port* port, bool is_in) {
  CORBA::TypeCode_var type = port->port_type();
  rtm::PortShape shape{is_in, rtm::type_name(type.in()), {}};
  typename Ex::_var_type ex = Ex::_narrow(port);
  if (!CORBA::is_nil(ex)) {
    RTM::PortDescription_var d = ex->describe();
    for (CORBA::ULong i = 0; i < d->elements.length(); ++i) shape.units.push_back(d->elements[i].unit.in());
  }
  return shape;
}

}  // namespace

rtm::Diagram servo_diagram(const std::string& servo, const std::string& sensor, const std::string& controller,
                           const std::string& actuator, bool ticked) {
  return {.name = servo + "'s wiring",
          .members = {{sensor}, {controller}, {actuator}},
          .ticked = ticked,
          .connections = {{{sensor, "wrench"}, {controller, "wrench"}}, {{controller, "twist"}, {actuator, "twist"}}}};
}

// ============================ RemoteServo =============================

RemoteServo::RemoteServo(std::string name, RTM::RtComponent_ptr sensor, RTM::RtComponent_ptr controller,
                         RTM::RtComponent_ptr actuator, std::chrono::nanoseconds phase_offset)
    : Component(std::move(name), "servo"),
      sensor_(RTM::RtComponent::_duplicate(sensor)),
      controller_(RTM::RtComponent::_duplicate(controller)),
      actuator_(RTM::RtComponent::_duplicate(actuator)),
      phase_offset_(phase_offset) {
  if (CORBA::is_nil(sensor_) || CORBA::is_nil(controller_) || CORBA::is_nil(actuator_))
    throw std::invalid_argument("servo " + this->name() + ": a member reference is nil");
  if (phase_offset_.count() < 0)
    throw std::invalid_argument(fmt::format("servo {}: phase offset {} ns is negative", this->name(),
                                            phase_offset_.count()));
  diagram_ = servo_diagram(this->name(), name_of(sensor_, "sensor"), name_of(controller_, "controller"),
                           name_of(actuator_, "actuator"), false);
  diagram_.check_structure();  // three distinct members
}

RTM::RtComponent_ptr RemoteServo::member(const std::string& name) const {
  const RTM::RtComponent_ptr members[3] = {sensor_.in(), controller_.in(), actuator_.in()};
  for (std::size_t i = 0; i < 3; ++i) {
    if (diagram_.members[i].name == name) return members[i];
  }
  return RTM::RtComponent::_nil();
}

RTM::InPort_ptr RemoteServo::reference_port() const {
  std::vector<std::string> names;
  RTM::InPort_var port = find_in(controller_, kServoReferencePort, &names);
  if (CORBA::is_nil(port)) {
    std::string have;
    for (const auto& n : names) have += (have.empty() ? "" : ", ") + n;
    throw std::runtime_error(fmt::format("servo {}: controller {} has no InPort {} (InPorts: {})", name(),
                                         diagram_.members[1].name, kServoReferencePort, have.empty() ? "none" : have));
  }
  return port._retn();
}

std::vector<RemoteServo::Link> RemoteServo::links() const {
  const rtm::PortCatalogue ports{
      .find = [this](const rtm::PortRef& ref, bool in) -> std::optional<rtm::PortShape> {
        RTM::RtComponent_ptr m = member(ref.member);
        if (CORBA::is_nil(m)) return std::nullopt;
        if (in) {
          RTM::InPort_var p = find_in(m, ref.port);
          if (!CORBA::is_nil(p)) return shape_of<RTM::InPortEx>(p.in(), true);
        } else {
          RTM::OutPort_var p = find_out(m, ref.port);
          if (!CORBA::is_nil(p)) return shape_of<RTM::OutPortEx>(p.in(), false);
        }
        return std::nullopt;
      },
      .names = [this](const std::string& name, bool in) {
        std::vector<std::string> names;
        RTM::RtComponent_ptr m = member(name);
        if (CORBA::is_nil(m)) return names;
        if (in) {
          RTM::InPort_var ignored = find_in(m, "", &names);
        } else {
          RTM::OutPort_var ignored = find_out(m, "", &names);
        }
        return names;
      },
  };
  if (auto problems = diagram_.problems(&ports); !problems.empty())
    throw rtm::DiagramError(diagram_.name, std::move(problems));
  std::vector<Link> result;
  for (const auto& c : diagram_.connections) {
    result.push_back({find_out(member(c.from.member), c.from.port), find_in(member(c.to.member), c.to.port), c.text()});
  }
  return result;
}

void RemoteServo::undo(bool turned_on[3], const std::vector<Link>& subscribed) {
  RTM::RtComponent_ptr members[3] = {actuator_.in(), controller_.in(), sensor_.in()};
  for (int i = 0; i < 3; ++i) {
    if (!turned_on[i]) continue;
    try {
      members[i]->off();
    } catch (const CORBA::Exception& e) {
      log().warn("servo {}: off() of {} raised {}", name(), name_of(members[i], "member"), e._name());
    }
  }
  for (const auto& l : subscribed) {
    try {
      l.from->unsubscribe(RTM::repeated, l.to);
    } catch (const CORBA::Exception& e) {
      log().warn("servo {}: unsubscribing {} raised {}", name(), l.text, e._name());
    }
  }
}

void RemoteServo::on_start() {
  bool turned_on[3] = {false, false, false};  // actuator, controller, sensor
  std::vector<Link> subscribed;
  std::string step = "check the wiring";
  try {
    for (const Link& l : links()) {
      step = "subscribe " + l.text;
      // A subscription left from an earlier run (a crash between on and off) is replaced.
      l.from->unsubscribe(RTM::repeated, l.to);
      if (!l.from->subscribe(RTM::repeated, l.to)) throw std::runtime_error(step + ": " + refusal_of(l.from));
      subscribed.push_back(l);
    }
    RTM::RtComponent_ptr members[3] = {actuator_.in(), controller_.in(), sensor_.in()};
    if (phase_offset_.count() == 0) {
      for (int i = 0; i < 3; ++i) {
        step = "on() " + name_of(members[i], "member");
        members[i]->on();
        turned_on[i] = true;
      }
    } else {
      // Upstream first, each a phase offset after the one feeding it (from the first on()).
      const auto first = std::chrono::steady_clock::now();
      for (int i = 2; i >= 0; --i) {
        std::this_thread::sleep_until(first + (2 - i) * phase_offset_);
        step = "on() " + name_of(members[i], "member");
        members[i]->on();
        turned_on[i] = true;
      }
    }
  } catch (const CORBA::Exception& e) {
    undo(turned_on, subscribed);
    throw std::runtime_error(fmt::format("servo {}: {} raised {}", name(), step, e._name()));
  } catch (const std::exception& e) {
    undo(turned_on, subscribed);
    throw std::runtime_error(fmt::format("servo {}: {}", name(), e.what()));
  }
  start_holding();
  log().info("servo {}: members connected and on ({})", name(),
             phase_offset_.count() == 0 ? std::string("downstream first")
                                        : fmt::format("sensor, controller, actuator {} us apart",
                                                      phase_offset_.count() / 1000));
}

void RemoteServo::start_holding() {
  {
    std::lock_guard lock(holder_mutex_);
    holder_stop_ = false;
  }
  std::vector<RTM::RtComponentEx_var> members;
  for (RTM::RtComponent_ptr m : {sensor_.in(), controller_.in(), actuator_.in()}) {
    RTM::RtComponentEx_var ex = RTM::RtComponentEx::_narrow(m);
    if (!CORBA::is_nil(ex)) members.push_back(ex);  // a plain RtComponent cannot be held
  }
  holder_ = std::thread([this, members = std::move(members)] {
    std::vector<bool> failed(members.size(), false);
    std::unique_lock lock(holder_mutex_);
    while (!holder_stop_) {
      lock.unlock();
      for (std::size_t i = 0; i < members.size(); ++i) {
        try {
          members[i]->hold(name().c_str(), kLeaseMs);
          failed[i] = false;
        } catch (const CORBA::Exception& e) {
          if (!failed[i]) log().warn("servo {}: hold on a member raised {}", name(), e._name());
          failed[i] = true;
        }
      }
      lock.lock();
      holder_wake_.wait_for(lock, std::chrono::milliseconds(kLeaseMs / 5), [this] { return holder_stop_; });
    }
    lock.unlock();
    for (const auto& m : members) {
      try {
        m->release(name().c_str());
      } catch (const CORBA::Exception&) {
      }
    }
  });
}

void RemoteServo::stop_holding() {
  {
    std::lock_guard lock(holder_mutex_);
    holder_stop_ = true;
  }
  holder_wake_.notify_all();
  if (holder_.joinable()) holder_.join();
}

void RemoteServo::on_stop() {
  stop_holding();
  bool all[3] = {true, true, true};
  bool none[3] = {false, false, false};
  undo(all, {});
  std::vector<Link> made;
  try {
    made = links();
  } catch (const std::exception& e) {
    log().warn("servo {}: finding its connections to remove: {}", name(), e.what());
  } catch (const CORBA::Exception& e) {
    log().warn("servo {}: finding its connections to remove raised {}", name(), e._name());
  }
  undo(none, made);
  log().info("servo {}: members off and disconnected", name());
}

// ============================ SharedTickServo =========================

std::int64_t phased_first_deadline(std::int64_t reference_ns, std::int64_t lead_ns, std::int64_t period_ns) {
  if (lead_ns < 0 || lead_ns >= period_ns)
    throw std::invalid_argument("tick lead " + std::to_string(lead_ns) + " ns: want 0 <= lead < the period (" +
                                std::to_string(period_ns) + " ns)");
  if (reference_ns <= 0) return 0;
  // A reference earlier than one lead after the clock's origin: its previous cycle's lead point.
  return reference_ns > lead_ns ? reference_ns - lead_ns : reference_ns - lead_ns + period_ns;
}

SharedTickServo::SharedTickServo(std::string name, std::unique_ptr<Sensor> sensor,
                                 std::unique_ptr<Controller> controller, std::unique_ptr<Actuator> actuator,
                                 rtm::PeriodicOptions tick, TickPhase phase, rtm::TickStage* bus)
    : Component(std::move(name), "servo"),
      sensor_logic_(sensor.get()),
      controller_logic_(controller.get()),
      actuator_logic_(actuator.get()),
      tick_(std::move(tick)),
      phase_(std::move(phase)),
      bus_(bus) {
  if (!sensor || !controller || !actuator)
    throw std::invalid_argument("servo " + this->name() + ": a member is missing");
  diagram_ = servo_diagram(this->name(), sensor->name(), controller->name(), actuator->name(), true);
  diagram_.check(rtm::catalogue_of({sensor.get(), controller.get(), actuator.get()}));
  if (bus_ && phase_.next_reference_deadline_ns)
    throw std::invalid_argument("servo " + this->name() +
                                ": a tick that runs the bus cycle cannot also be phased against it");
  phased_first_deadline(0, phase_.lead_ns, tick_.options().period_ns);  // validates the lead
  sensor_ = new rtm::ComponentServant(std::move(sensor), rtm::ExternalTick{});
  controller_ = new rtm::ComponentServant(std::move(controller), rtm::ExternalTick{});
  actuator_ = new rtm::ComponentServant(std::move(actuator), rtm::ExternalTick{});
  for (auto* member : {sensor_.in(), controller_.in(), actuator_.in()}) member->set_timing_source(&tick_);
  // A failed member must not stop the tick by itself: the actuator still has to run (its
  // watchdog zeroes the arm), the bus cycle to carry its command, and this servo's own cycle
  // (added after them, see add_to_tick) reports the failure and stops the tick.
  auto keep_going = [](rtm::CycleFunction f) {
    return [f = std::move(f)](const rtm::CycleContext& ctx) {
      f(ctx);
      return true;
    };
  };
  if (bus_) {
    add_counters(counters_);
    tick_.add([this](const rtm::CycleContext& ctx) {
      if (bus_cycle_is_mine(ctx) && !bus_->receive(ctx.deadline_ns)) bus_lost_.store(true);
      return true;
    });
  }
  // The actuator too: in error it has commanded zero (its on_stop), which the bus transmit
  // below still sends; the servo's own cycle then reports the failed member and stops the tick.
  for (const auto& m : diagram_.members) tick_.add(keep_going(servant(m.name).cycle_function()));
  if (bus_) {
    tick_.add([this](const rtm::CycleContext& ctx) {
      if (!bus_cycle_is_mine(ctx)) return true;
      if (bus_->transmit(ctx.deadline_ns))
        last_transmit_deadline_ns_.store(ctx.deadline_ns, std::memory_order_relaxed);
      else
        bus_lost_.store(true);
      return true;
    });
  }
}

rtm::CycleFunction SharedTickServo::handing_back_on_stop(rtm::CycleFunction cycle) {
  return [this, cycle = std::move(cycle)](const rtm::CycleContext& ctx) {
    if (cycle(ctx)) return true;
    hand_back_bus(ctx.deadline_ns + ctx.period_ns);
    return false;
  };
}

void SharedTickServo::hand_back_bus(std::int64_t next_deadline_ns) {
  if (bus_taken_.exchange(false)) bus_->hand_back(next_deadline_ns);
}

SharedTickServo::~SharedTickServo() {
  tick_.stop();
  hand_back_bus(0);
  // Sensor first: it may read the master the actuator owns.
  for (auto* member : {sensor_.in(), controller_.in(), actuator_.in()}) {
    try {
      member->off();
    } catch (...) {
    }
    member->deactivate();
  }
  sensor_ = nullptr;
  controller_ = nullptr;
  actuator_ = nullptr;
}

void SharedTickServo::activate_members(rtm::Orb& orb) {
  for (auto* member : {sensor_.in(), controller_.in(), actuator_.in()}) {
    RTM::RtComponentEx_var ref = member->activate(orb);
  }
}

RTM::InPort_ptr SharedTickServo::reference_port() const {
  RTM::InPortEx_var ref = controller_logic_->reference_in().reference();
  if (CORBA::is_nil(ref)) throw std::logic_error("servo " + name() + ": members not activated");
  return RTM::InPort::_duplicate(ref.in());
}

rtm::ComponentServant& SharedTickServo::servant(const std::string& member) {
  for (auto* s : {sensor_.in(), controller_.in(), actuator_.in()}) {
    if (s->component().name() == member) return *s;
  }
  throw std::logic_error("servo " + name() + ": no member " + member);
}

std::string SharedTickServo::connect_members() {
  disconnect_members();  // a connection left from an earlier run is replaced
  for (const auto& c : diagram_.connections) {
    auto* out = rtm::out_port_of(servant(c.from.member).component(), c.from.port);
    auto* in = rtm::in_port_of(servant(c.to.member).component(), c.to.port);
    if (!out || !in) return c.text() + ": no such port";  // the constructor's check makes this unreachable
    if (!out->connect_local(*in, c.policy)) return c.text() + ": " + out->last_error_text();
  }
  return "";
}

void SharedTickServo::disconnect_members() {
  for (const auto& c : diagram_.connections) {
    auto* out = rtm::out_port_of(servant(c.from.member).component(), c.from.port);
    auto* in = rtm::in_port_of(servant(c.to.member).component(), c.to.port);
    if (out && in) out->disconnect_local(*in);
  }
}

void SharedTickServo::on_start() {
  if (const std::string why = connect_members(); !why.empty()) {
    disconnect_members();
    throw std::runtime_error("servo " + name() + ": connecting the members failed: " + why);
  }
  try {
    actuator_->on();
    controller_->on();
    sensor_->on();
  } catch (const CORBA::Exception& e) {
    actuator_->off();
    controller_->off();
    sensor_->off();
    std::string why;
    for (auto* member : {sensor_.in(), controller_.in(), actuator_.in()}) {
      if (member->current_state() == RTM::COMPONENT_ERROR)
        why += " " + member->component().name() + ": " + member->error_text();
    }
    throw std::runtime_error("servo " + name() + ": turning the members on failed:" + why);
  }
  std::int64_t first_ns = 0;
  if (bus_) {
    first_ns = bus_->take_over();  // the bus master's activity stops before its next deadline
    bus_taken_.store(true);
    bus_lost_.store(false);
    bus_resume_ns_.store(0, std::memory_order_relaxed);
    last_transmit_deadline_ns_.store(0, std::memory_order_relaxed);
  } else if (phase_.next_reference_deadline_ns) {
    first_ns = phased_first_deadline(phase_.next_reference_deadline_ns(), phase_.lead_ns, tick_.options().period_ns);
  }
  tick_.set_first_deadline_ns(first_ns);
  try {
    tick_.start();
  } catch (...) {
    hand_back_bus(first_ns);
    throw;
  }
  if (bus_)
    log().info("servo {}: shared tick running the bus cycle: receive, sensor -> controller -> actuator, transmit",
               name());
  else if (first_ns != 0)
    log().info("servo {}: shared tick running sensor -> controller -> actuator, {} us before each bus cycle", name(),
               phase_.lead_ns / 1000);
  else
    log().info("servo {}: shared tick running sensor -> controller -> actuator", name());
}

void SharedTickServo::on_cycle(const rtm::CycleContext&) {
  if (bus_lost_.load()) retake_bus();
  for (auto* member : {sensor_.in(), controller_.in(), actuator_.in()}) {
    if (member->current_state() == RTM::COMPONENT_ERROR)
      throw std::runtime_error("member " + member->component().name() + " failed: " + member->error_text());
  }
}

// The bus master's watchdog took the cycles back: this tick sent no SYNC for several periods
// while the watchdog woke on time (this thread's CPU stalled, or higher-priority work held the
// tick off). The master's own thread runs them meanwhile, on this tick's grid, holding the
// drives at zero (FaultKind::cycle_owner_lost, which the actuator resets as a command loss).
// The tick is running again, so it takes them again: take_over() waits for the master's cycle
// in progress and returns the first deadline that thread did not run; the bus halves of the
// tick's cycles before it are skipped, so no period carries two SYNCs.
void SharedTickServo::retake_bus() {
  const std::int64_t resume_ns = bus_->take_over();
  bus_resume_ns_.store(resume_ns, std::memory_order_relaxed);
  bus_lost_.store(false);
  const std::uint64_t event = counters_.bus_retakes.add();
  log().warn("servo {}: the bus master had taken its cycles back (this tick sent no SYNC for too long): running "
             "them again from the next deadline, the actuator resumes on the next command (retake {})",
             name(), event);
}

void SharedTickServo::on_stop() {
  tick_.stop();
  // Joined (or, from the tick's own thread, its last cycle has run): the bus master's thread
  // takes the cycles back on the tick's grid, before the actuator's off() waits for its zero
  // command to leave.
  const std::int64_t last_ns = last_transmit_deadline_ns_.load(std::memory_order_relaxed);
  hand_back_bus(last_ns > 0 ? last_ns + tick_.options().period_ns : 0);
  actuator_->off();
  controller_->off();
  sensor_->off();
  disconnect_members();
  log().info("servo {}: members off", name());
}

}  // namespace rtm::comp
