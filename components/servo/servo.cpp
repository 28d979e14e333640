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

}  // namespace

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
}

RTM::InPort_ptr RemoteServo::reference_port() const {
  RTM::InPortList_var ins = controller_->in_ports();
  if (ins->length() < 2)
    throw std::runtime_error(fmt::format("servo {}: controller {} has {} InPorts, the reference is InPort 1", name(),
                                         name_of(controller_, "controller"), ins->length()));
  return RTM::InPort::_duplicate(ins[1]);
}

RemoteServo::Link RemoteServo::link(RTM::RtComponent_ptr from, const char* from_role, RTM::RtComponent_ptr to,
                                    const char* to_role, CORBA::ULong in_index) const {
  Link result;
  result.text = fmt::format("{}.out0 -> {}.in{}", name_of(from, from_role), name_of(to, to_role), in_index);
  RTM::OutPortList_var outs = from->out_ports();
  RTM::InPortList_var ins = to->in_ports();
  if (outs->length() < 1 || ins->length() <= in_index)
    throw std::runtime_error(fmt::format("servo {}: {}: port missing ({} has {} OutPorts, {} has {} InPorts)", name(),
                                         result.text, from_role, outs->length(), to_role, ins->length()));
  result.from = RTM::OutPort::_duplicate(outs[0]);
  result.to = RTM::InPort::_duplicate(ins[in_index]);
  return result;
}

void RemoteServo::undo(bool turned_on[3], bool subscribed[2]) {
  RTM::RtComponent_ptr members[3] = {actuator_.in(), controller_.in(), sensor_.in()};
  for (int i = 0; i < 3; ++i) {
    if (!turned_on[i]) continue;
    try {
      members[i]->off();
    } catch (const CORBA::Exception& e) {
      log().warn("servo {}: off() of {} raised {}", name(), name_of(members[i], "member"), e._name());
    }
  }
  for (int i = 0; i < 2; ++i) {
    if (!subscribed[i]) continue;
    try {
      const Link l = i == 0 ? link(sensor_, "sensor", controller_, "controller", 0)
                            : link(controller_, "controller", actuator_, "actuator", 0);
      l.from->unsubscribe(RTM::repeated, l.to);
    } catch (const CORBA::Exception& e) {
      log().warn("servo {}: unsubscribe raised {}", name(), e._name());
    } catch (const std::exception& e) {
      log().warn("servo {}: unsubscribe failed: {}", name(), e.what());
    }
  }
}

void RemoteServo::on_start() {
  bool turned_on[3] = {false, false, false};  // actuator, controller, sensor
  bool subscribed[2] = {false, false};
  std::string step;
  try {
    const Link links[2] = {link(sensor_, "sensor", controller_, "controller", 0),
                           link(controller_, "controller", actuator_, "actuator", 0)};
    for (int i = 0; i < 2; ++i) {
      step = "subscribe " + links[i].text;
      // A subscription left from an earlier run (a crash between on and off) is replaced.
      links[i].from->unsubscribe(RTM::repeated, links[i].to);
      if (!links[i].from->subscribe(RTM::repeated, links[i].to))
        throw std::runtime_error(step + ": " + refusal_of(links[i].from));
      subscribed[i] = true;
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
  bool both[2] = {true, true};
  undo(all, both);
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
                                 rtm::PeriodicOptions tick, TickPhase phase, TickBusCycle bus)
    : Component(std::move(name), "servo"),
      sensor_logic_(sensor.get()),
      controller_logic_(controller.get()),
      actuator_logic_(actuator.get()),
      tick_(std::move(tick)),
      phase_(std::move(phase)),
      bus_(std::move(bus)) {
  if (!sensor || !controller || !actuator)
    throw std::invalid_argument("servo " + this->name() + ": a member is missing");
  if ((bus_.take_over || bus_.hand_back || bus_.receive || bus_.transmit) &&
      !(bus_.take_over && bus_.hand_back && bus_.receive && bus_.transmit))
    throw std::invalid_argument("servo " + this->name() + ": the bus cycle needs take_over, hand_back, receive and transmit");
  if (bus_.set() && phase_.next_reference_deadline_ns)
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
  if (bus_.set()) {
    add_counters(counters_);
    tick_.add([this](const rtm::CycleContext& ctx) {
      if (bus_cycle_is_mine(ctx) && !bus_.receive()) bus_lost_.store(true);
      return true;
    });
  }
  // The actuator too: in error it has commanded zero (its on_stop), which the bus transmit
  // below still sends; the servo's own cycle then reports the failed member and stops the tick.
  tick_.add(keep_going(sensor_->cycle_function()));
  tick_.add(keep_going(controller_->cycle_function()));
  tick_.add(keep_going(actuator_->cycle_function()));
  if (bus_.set()) {
    tick_.add([this](const rtm::CycleContext& ctx) {
      if (!bus_cycle_is_mine(ctx)) return true;
      if (bus_.transmit())
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
  if (bus_taken_.exchange(false)) bus_.hand_back(next_deadline_ns);
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

void SharedTickServo::on_start() {
  sensor_logic_->out().disconnect(controller_logic_->sensor_in());
  controller_logic_->command_out().disconnect(actuator_logic_->command_in());
  if (!sensor_logic_->out().connect(controller_logic_->sensor_in()) ||
      !controller_logic_->command_out().connect(actuator_logic_->command_in()))
    throw std::runtime_error("servo " + name() + ": connecting the members failed: " +
                             sensor_logic_->out().last_refusal() + controller_logic_->command_out().last_refusal());
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
  if (bus_.set()) {
    first_ns = bus_.take_over();  // the bus master's activity stops before its next deadline
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
  if (bus_.set())
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
  const std::int64_t resume_ns = bus_.take_over();
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
  sensor_logic_->out().disconnect(controller_logic_->sensor_in());
  controller_logic_->command_out().disconnect(actuator_logic_->command_in());
  log().info("servo {}: members off", name());
}

}  // namespace rtm::comp
