// SPDX-License-Identifier: Apache-2.0
// A ticked diagram run in this process: its members are ExternalTick components, and one
// SharedTick runs them every period in the order the diagram lists them. With a TickStage (the
// CAN master's SYNC cycle) the tick runs the stage too:
//
//   stage.receive(now), member 1, member 2, ..., member N, stage.transmit(now)
//
// so a datum that enters at the first member leaves with the transmit of the same cycle, on
// one thread, with nothing to wake. The force servo's shared-tick mode is one of these, built
// from its declaration (components/servo: servo_diagram()); any other ticked diagram runs the
// same way.
//
//   on():  the diagram's connections made in-process, members on (last first: no datum reaches
//          a member that is not running), the stage taken over, the tick started;
//   off(): the tick stopped, the stage handed back on the tick's grid, members off (last
//          first), connections removed.
// A member that fails does not stop the tick by itself: the members after it and the stage
// still run (an actuator in error has commanded zero, which the transmit still sends), and the
// composite's own cycle (add_to_tick) then reports it and stops the tick.
#pragma once

#include "rt/activity.h"
#include "rt/tick_stage.h"
#include "rtm/component.h"
#include "rtm/diagram.h"

#include <RTMExt.hh>

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace rtm {

// Where a tick without a stage puts its cycles: lead_ns before those of a reference grid (the
// bus master's SYNC cycles run on its own thread), so a command computed in the tick leaves
// with the very next SYNC instead of up to a period later. next_reference_deadline_ns returns
// the reference's next CLOCK_MONOTONIC deadline on the tick's period, 0 when it has none (the
// tick then starts at once).
struct TickPhase {
  std::function<std::int64_t()> next_reference_deadline_ns;
  std::int64_t lead_ns = 100'000;
};

// The tick's first deadline for a reference grid whose next deadline is reference_ns: lead_ns
// earlier (PeriodicActivity moves a deadline already past onto the same grid). 0 (start at
// once) when there is no reference. Throws std::invalid_argument unless 0 <= lead_ns < period_ns.
std::int64_t phased_first_deadline(std::int64_t reference_ns, std::int64_t lead_ns, std::int64_t period_ns);

class TickedComposite final : public Component {
 public:
  // diagram: ticked, its members exactly the components given (by name; the tick runs them in
  // the diagram's order), checked against their ports (DiagramError lists every problem).
  // stage: run by the tick, taken over in on_start() and handed back in on_stop() or as soon
  // as a stage added by add_to_tick() stops the tick; must outlive the composite. phase: where
  // the tick's cycles fall when there is no stage. Throws std::invalid_argument when the
  // members do not match the diagram, or when both a stage and a phase reference are given.
  TickedComposite(std::string name, std::string kind, Diagram diagram, std::vector<std::unique_ptr<Component>> members,
                  PeriodicOptions tick, TickPhase phase = {}, TickStage* stage = nullptr);
  // Members are destroyed in the diagram's order: an upstream member may read what a
  // downstream one owns (the sensor reads the CAN master the actuator's arm owns).
  ~TickedComposite() override;

  // Activates the members in orb: their ports become reachable (e.g. to expose one as the
  // composite's own, see in_port()).
  void activate_members(Orb& orb);
  // The CORBA reference of a member's InPort, after activate_members(); the caller owns it.
  // Throws std::invalid_argument when the member or the port does not exist.
  RTM::InPort_ptr in_port(const PortRef& port) const;

  // Appended to the tick after the members and the stage's transmit (e.g. the composite
  // servant's own cycle_function(), so a failed member puts the composite in error). Only
  // while off.
  void add_to_tick(CycleFunction cycle) { tick_.add(handing_back_on_stop(std::move(cycle))); }
  bool runs_stage() const { return stage_ != nullptr; }
  const Diagram& diagram() const { return diagram_; }
  const SharedTick& tick() const { return tick_; }
  // The members' servants, in the diagram's order.
  const std::vector<ComponentServant*>& members() const { return servants_; }
  // Throws std::invalid_argument when there is no member of that name.
  ComponentServant& member(std::string_view name) const;

  void on_start() override;
  // Runs in the tick after the members: a member in COMPONENT_ERROR fails the composite. A
  // stage that took its cycles back from the tick (the tick fell silent for too long: a stall)
  // gets them taken again, from its next deadline on. Counted as stage_retakes.
  void on_cycle(const CycleContext&) override;
  void on_stop() override;

 private:
  std::vector<PortableServer::Servant_var<ComponentServant>> owned_;  // the diagram's order
  std::vector<ComponentServant*> servants_;
  Diagram diagram_;
  SharedTick tick_;
  TickPhase phase_;
  TickStage* stage_;
  std::atomic<bool> stage_taken_{false};
  std::atomic<bool> stage_lost_{false};          // the stage took its cycles back from the tick
  std::atomic<std::int64_t> stage_resume_ns_{0};  // after a retake: the first deadline whose cycle is the tick's
  std::atomic<std::int64_t> last_transmit_deadline_ns_{0};
  struct Counters : CounterSet {
    Counter stage_retakes{*this, "stage_retakes",
                          "stage cycles (the bus master's) taken again after the stage took them back from a late tick"};
  } counters_;

  void add_stage_and_members();
  // A cycle after the stage's transmit that stops the tick gives the stage's cycles back
  // first, due on the next deadline: the drives miss no SYNC.
  CycleFunction handing_back_on_stop(CycleFunction cycle);
  void hand_back_stage(std::int64_t next_deadline_ns);
  void retake_stage();
  void turn_members_off();
  // The diagram's connections made (in-process) or removed; connect returns "" or why not.
  std::string connect_members();
  void disconnect_members();
  bool stage_cycle_is_mine(const CycleContext& ctx) const {
    return ctx.deadline_ns >= stage_resume_ns_.load(std::memory_order_relaxed);
  }
};

}  // namespace rtm
