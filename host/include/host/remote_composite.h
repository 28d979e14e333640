// SPDX-License-Identifier: Apache-2.0
// A diagram whose members are RT components anywhere (the paper's composite, Figs. 4, 8):
// each runs on its own activity, and the composite only wires them and turns them on and off.
//
//   on():  the diagram checked against the members' ports (remote reads only; every problem
//          at once), its connections subscribed (repeated), the members turned on, and held
//          (HoldRenewal) while on;
//   off(): the members off (last first: the actuator brakes before its command stream ends, so
//          no watchdog fires), the holds released, the subscriptions removed.
// On any failure on() undoes what it did and throws std::runtime_error naming the step.
//
// Each member's activity keeps an absolute schedule from its own on(), so the order and
// spacing of the on() calls set the phase between the members' cycles: with phases declared
// in the diagram (Diagram::Member::phase_ns) on() turns the members on in the order of their
// phases, each phase_ns after the first on(), so each cycle finds the datum its upstream member
// produced a phase earlier (the actuator's watchdog arms only with its first command, so the
// upstream members running first cost no event). With every phase 0 the order is last first
// (no datum reaches a member that is not running), and each stage waits up to a period.
#pragma once

#include "host/lease.h"
#include "rtm/component.h"
#include "rtm/diagram.h"

#include <RTMExt.hh>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace rtm {

class RemoteComposite final : public Component {
 public:
  struct Member {
    std::string name;  // as the diagram names it
    RTM::RtComponent_var ref;
  };
  // diagram: not ticked, its members exactly those given (by name). Throws
  // std::invalid_argument when a reference is nil or the members do not match the diagram,
  // DiagramError when its structure does not hold (e.g. a phase out of the period).
  RemoteComposite(std::string name, std::string kind, Diagram diagram, std::vector<Member> members);
  ~RemoteComposite() override;

  // A member's InPort, to expose as the composite's own. Throws std::runtime_error naming the
  // member's InPorts when it has none of that name.
  RTM::InPort_ptr in_port(const PortRef& port) const;
  const Diagram& diagram() const { return diagram_; }

  void on_start() override;
  void on_cycle(const CycleContext&) override {}  // the members run themselves
  void on_stop() override;

  static constexpr std::uint32_t kLeaseMs = 500;

 private:
  struct Link {
    RTM::OutPort_var from;
    RTM::InPort_var to;
    std::string text;  // "sensor0.wrench -> controller0.wrench"
  };
  RTM::RtComponent_ptr member(const std::string& name) const;
  // The ports of the diagram's connections, found by name. Throws DiagramError listing every
  // problem of the diagram against the members' ports.
  std::vector<Link> links() const;
  // The order on() turns the members on (indexes into members_): by phase, or last first.
  std::vector<std::size_t> turn_on_order() const;
  void undo(const std::vector<std::size_t>& turned_on, const std::vector<Link>& subscribed);

  Diagram diagram_;
  std::vector<Member> members_;  // the diagram's order
  std::unique_ptr<HoldRenewal> holds_;  // while on
};

}  // namespace rtm
