// SPDX-License-Identifier: Apache-2.0
// Servo: the composite of the paper (Figs. 4, 8). It owns a sensor, a controller and an
// actuator and hides them. What it is, is a declaration: servo_diagram(), the three members in
// the order a cycle runs them and their wiring by port name, checked once against the
// members' ports before anything is wired. Both run modes make their connections from it:
//   on():  sensor.wrench -> controller.wrench and controller.twist -> actuator.twist
//          (repeated), then on() each member (see RemoteServo for the order);
//   off(): off() each member (actuator first: the arm gets zero velocity before its command
//          stream ends, so no watchdog fires), then the connections are removed.
// Its own InPort 0 IS the controller's InPort "reference": the servo's servant hands out the
// controller's (ComponentServant::expose_in_port), so a put on it lands directly in the
// controller.
//
// Two run modes:
//   RemoteServo       the paper's: members are RT components anywhere (found by name), each on
//                     its own periodic activity;
//   SharedTickServo   members live in this process as ExternalTick components and one
//                     SharedTick runs sensor -> controller -> actuator in that order every
//                     period, between the bus master's receive and transmit, so a sensor
//                     sample reaches the drives with the SYNC of the same cycle.
#pragma once

#include "components/actuator/actuator.h"
#include "components/controller/controller.h"
#include "components/sensor/sensor.h"

#include "rt/activity.h"
#include "rt/tick_stage.h"
#include "rtm/component.h"
#include "rtm/diagram.h"

#include <RTMExt.hh>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace rtm::comp {

// The servo's members, in the order a shared tick runs them, and its wiring: the sensor's
// wrench into the controller's, the controller's twist into the actuator's. ticked: one
// thread runs them in that order (the shared tick).
rtm::Diagram servo_diagram(const std::string& servo, const std::string& sensor, const std::string& controller,
                           const std::string& actuator, bool ticked);
// The controller's InPort the servo hands out as its own.
inline constexpr const char* kServoReferencePort = "reference";

// ============================ RemoteServo =============================

class RemoteServo final : public rtm::Component {
 public:
  // The three members' references (e.g. from NamingClient::resolve_component). Throws
  // std::invalid_argument when one is nil or phase_offset is negative.
  //
  // Each member's activity keeps an absolute schedule from its own on(), so the order and
  // spacing of the on() calls set the phase between the members' cycles. With phase_offset > 0
  // on() turns them on sensor, controller, actuator, the second phase_offset and the third
  // 2 * phase_offset after the first: each cycle then finds the datum its upstream member
  // produced phase_offset earlier (a sample reaches the drives within about 2 * phase_offset,
  // not 2 periods; period/4 leaves room for the CORBA hop and wake-up jitter). The actuator's
  // watchdog arms only with its first command, so the upstream members running first cost no
  // event. With phase_offset 0 the order is downstream first (actuator, controller, sensor: no
  // datum reaches a member that is not running), and each stage waits up to a period.
  RemoteServo(std::string name, RTM::RtComponent_ptr sensor, RTM::RtComponent_ptr controller,
              RTM::RtComponent_ptr actuator, std::chrono::nanoseconds phase_offset = std::chrono::nanoseconds(0));
  ~RemoteServo() override { stop_holding(); }

  // The controller's InPort "reference", to expose as the servo's InPort 0. Throws
  // std::runtime_error naming the controller's InPorts when it has none of that name.
  RTM::InPort_ptr reference_port() const;
  const rtm::Diagram& diagram() const { return diagram_; }

  // Subscribes and turns the members on; on any failure undoes what it did and throws
  // std::runtime_error naming the member and the reason.
  void on_start() override;
  void on_cycle(const rtm::CycleContext&) override {}  // the members run themselves
  void on_stop() override;

 private:
  struct Link {
    RTM::OutPort_var from;
    RTM::InPort_var to;
    std::string text;  // "sensor0.wrench -> controller0.wrench"
  };
  // The members by the names the diagram gives them.
  RTM::RtComponent_ptr member(const std::string& name) const;
  // The ports of the diagram's connections, found by name. Throws std::runtime_error listing
  // every problem of the diagram against the members' ports (rtm::Diagram::problems).
  std::vector<Link> links() const;
  void undo(bool turned_on[3], const std::vector<Link>& subscribed);
  // While on, the servo holds its members (RtComponentEx::hold, renewed every lease/5): when
  // its process dies they turn themselves off within the lease instead of running on, wired
  // and out of anyone's reach.
  void start_holding();
  void stop_holding();

  RTM::RtComponent_var sensor_, controller_, actuator_;
  rtm::Diagram diagram_;
  std::chrono::nanoseconds phase_offset_;
  std::thread holder_;
  std::mutex holder_mutex_;
  std::condition_variable holder_wake_;
  bool holder_stop_ = false;

 public:
  static constexpr std::uint32_t kLeaseMs = 500;
};

// ============================ SharedTickServo =========================

// Where the shared tick's cycles fall: lead_ns before the cycles of a reference grid (the bus
// master's SYNC cycles), so a command computed in the tick leaves with the very next SYNC
// instead of up to a period later. next_reference_deadline_ns returns the reference's next
// CLOCK_MONOTONIC deadline on the tick's period, 0 when it has none (the tick then starts at once).
struct TickPhase {
  std::function<std::int64_t()> next_reference_deadline_ns;
  std::int64_t lead_ns = 100'000;
};

// The bus master's SYNC cycle run by the tick itself: a TickStage (rt/tick_stage.h; the
// Pa10Master is one). The tick receives before the sensor and transmits after the actuator,
// so a command computed from a sample leaves with the very next SYNC, in the same cycle and on
// the same thread, with no second thread to wake. When receive or transmit returns false the
// bus master has taken its cycles back because the tick fell silent (Pa10Master:
// taken_over_timeout_periods); the servo takes them again.

// The tick's first deadline for a reference grid whose next deadline is reference_ns: lead_ns
// earlier (PeriodicActivity moves a deadline already past onto the same grid). 0 (start at
// once) when there is no reference. Throws std::invalid_argument unless 0 <= lead_ns < period_ns.
std::int64_t phased_first_deadline(std::int64_t reference_ns, std::int64_t lead_ns, std::int64_t period_ns);

class SharedTickServo final : public rtm::Component {
 public:
  // Members become ExternalTick servants run by one SharedTick with `tick` (period, priority,
  // CPU). The actuator's arm must outlive nothing else here: members are destroyed sensor
  // first, actuator last (a sensor may read the actuator's master).
  //
  // Where the bus cycle happens: with `bus` set the tick runs it (bus receive, sensor,
  // controller, actuator, bus transmit), taking it over in on_start() and handing it back in
  // on_stop() or as soon as a stage stops the tick; otherwise the tick runs on its own,
  // phased by `phase` against the bus master's cycles. `bus` must outlive the servo. Throws
  // std::invalid_argument when a member is missing, or when both `bus` and a phase reference
  // are given.
  SharedTickServo(std::string name, std::unique_ptr<Sensor> sensor, std::unique_ptr<Controller> controller,
                  std::unique_ptr<Actuator> actuator, rtm::PeriodicOptions tick, TickPhase phase = {},
                  rtm::TickStage* bus = nullptr);
  ~SharedTickServo() override;

  // Activates the three members in orb (their ports become reachable; the servo exposes the
  // controller's InPort "reference" through reference_port()).
  void activate_members(rtm::Orb& orb);
  RTM::InPort_ptr reference_port() const;  // after activate_members()

  // Appended to the tick after the three members and the bus transmit (e.g. the servo
  // servant's own cycle_function(), so a failed member puts the servo in error). Only while off.
  void add_to_tick(rtm::CycleFunction cycle) { tick_.add(handing_back_on_stop(std::move(cycle))); }
  bool runs_bus_cycle() const { return bus_ != nullptr; }
  const rtm::Diagram& diagram() const { return diagram_; }

  void on_start() override;
  // Runs in the tick after the members: a member in COMPONENT_ERROR fails the servo. A bus
  // master that took its cycles back from the tick (the tick sent no SYNC for too long: a
  // stall) gets them taken again, from its next deadline on; the actuator resumes as from a
  // command loss. Counted as bus_retakes.
  void on_cycle(const rtm::CycleContext&) override;
  void on_stop() override;

  rtm::ComponentServant& sensor() { return *sensor_; }
  rtm::ComponentServant& controller() { return *controller_; }
  rtm::ComponentServant& actuator() { return *actuator_; }
  const rtm::SharedTick& tick() const { return tick_; }

 private:
  PortableServer::Servant_var<rtm::ComponentServant> sensor_, controller_, actuator_;
  Sensor* sensor_logic_;
  Controller* controller_logic_;
  Actuator* actuator_logic_;
  rtm::Diagram diagram_;  // checked against the members' ports in the constructor
  rtm::SharedTick tick_;
  TickPhase phase_;
  rtm::TickStage* bus_;
  std::atomic<bool> bus_taken_{false};
  std::atomic<bool> bus_lost_{false};  // the bus master took its cycles back from the tick
  std::atomic<std::int64_t> bus_resume_ns_{0};  // after a retake: the first deadline whose cycle is the tick's
  struct Counters : rtm::CounterSet {
    rtm::Counter bus_retakes{*this, "bus_retakes",
                             "bus cycles taken again after the master took them back from a late tick"};
  } counters_;
  std::atomic<std::int64_t> last_transmit_deadline_ns_{0};

  // A stage after the bus transmit that stops the tick gives the bus cycles back first, due
  // on the next deadline: the drives miss no SYNC.
  rtm::CycleFunction handing_back_on_stop(rtm::CycleFunction cycle);
  void hand_back_bus(std::int64_t next_deadline_ns);
  void retake_bus();
  // The diagram's connections made (in-process) or removed; connect returns "" or why not.
  std::string connect_members();
  void disconnect_members();
  rtm::ComponentServant& servant(const std::string& member);
  bool bus_cycle_is_mine(const rtm::CycleContext& ctx) const {
    return ctx.deadline_ns >= bus_resume_ns_.load(std::memory_order_relaxed);
  }
};

}  // namespace rtm::comp
