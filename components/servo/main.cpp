// SPDX-License-Identifier: Apache-2.0
// rtm-servo: the force-servo composite (paper Figs. 4, 8).
//
// Paper mode (default): --sensor/--controller/--actuator name RT components found through the
// naming service (waited for up to --wait); on() wires sensor.wrench -> controller.wrench and
// controller.twist -> actuator.twist and turns them on; off() reverses it.
// Shared-tick mode (--shared-tick): the three members are created in this process on the
// arm's bus (--bus, --sensor-bus) and run by one periodic tick, sensor -> controller ->
// actuator in that order; they are also bound by those names, for browsing.
// In both modes the servo's InPort 0 is the controller's InPort "reference"; the wiring is
// servo_diagram(), checked against the members' ports before anything is connected, and the
// host runs it: rtm::RemoteComposite in paper mode, rtm::TickedComposite with --shared-tick.
// --cpu pins the tick and the bus master's thread, not the whole process.
// Timing contracts (docs/timing.md): with --shared-tick each member's cycle is watched against
// its own budget and the tick's deadline; --watch-chain NAME:MEMBER.PORT makes a member a
// chain's end, and --stamp-from MEMBER.OUT=IN a member's OutPort pass its input's stamp on.
#include "components/actuator/actuator.h"
#include "components/controller/controller.h"
#include "components/sensor/sensor.h"
#include "components/servo/servo.h"

#include "host/remote_composite.h"
#include "host/module.h"
#include "host/ticked_composite.h"
#include "rtm/naming.h"
#include "rtm/orb.h"

#include <CLI/CLI.hpp>

#include <chrono>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace {

using namespace std::chrono_literals;

struct ServoOptions {
  bool shared_tick = false;
  double wait_s = 10;
  double phase_offset_us = -1;  // -1: a quarter of the period
  std::string sensor = "sensor0", controller = "controller0", actuator = "actuator0";
  // Shared tick only.
  std::string bus_cycle = "tick";
  double tick_lead_us = 100;  // > the tick's lateness p99 (40-60 us) + its cycle (~25 us)
  CLI::Option* tick_lead_option = nullptr;
  rtm::pa10::ArmHardware::Options hardware;
  rtm::comp::ControllerParams controller_params;
  rtm::comp::ActuatorParams actuator_params;

  void add_options(CLI::App& app) {
    app.add_option("--sensor", sensor, "sensor member name (shared tick: the name it is bound as)")
        ->capture_default_str();
    app.add_option("--controller", controller, "controller member name")->capture_default_str();
    app.add_option("--actuator", actuator, "actuator member name")->capture_default_str();
    app.add_option("--wait", wait_s, "paper mode: seconds to wait for the members to appear")->capture_default_str();
    app.add_option("--phase-offset-us", phase_offset_us,
                   "paper mode: turn members on sensor, controller, actuator this far apart (µs) so each cycle "
                   "finds its input fresh; 0 = downstream first; default: a quarter of --period")
        ->check(CLI::Range(-1.0, 1e6));
    app.add_flag("--shared-tick", shared_tick, "run the members in this process on one periodic tick");
    auto* group = app.add_option_group("shared tick", "members made by --shared-tick");
    group->add_option("--bus-cycle", bus_cycle,
                      "who runs the CAN master's SYNC cycle: 'tick' (the tick itself: receive, sensor -> controller "
                      "-> actuator, transmit; a sample reaches the drives in the same cycle) or 'master' (its own "
                      "thread; the tick runs --tick-lead-us before it)")
        ->check(CLI::IsMember({"tick", "master"}))
        ->capture_default_str();
    tick_lead_option = group->add_option("--tick-lead-us", tick_lead_us,
                                         "--bus-cycle master: the tick's cycles fall this long before the master's "
                                         "SYNC cycles, so a command leaves with the next SYNC (0 <= lead < --period)")
                           ->capture_default_str();
    hardware.add_options(*group);
    rtm::add_parameter_options(*group, rtm::comp::controller_parameters(), controller_params);
    rtm::add_parameter_options(*group, rtm::comp::actuator_parameters(), actuator_params);
  }

  void validate() const {
    if (tick_lead_option->count() > 0 && bus_cycle != "master")
      throw CLI::ValidationError("--tick-lead-us", "applies to --bus-cycle master only");
    controller_params.validate();
    actuator_params.validate();
  }
};

RTM::RtComponent_var wait_for_component(const rtm::NamingClient& naming, const std::string& name, double wait_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(wait_s);
  for (;;) {
    try {
      return naming.resolve_component(name);
    } catch (const rtm::NamingError& e) {
      if (std::chrono::steady_clock::now() >= deadline)
        throw std::runtime_error("member " + name + " not found within " + std::to_string(wait_s) + " s: " + e.what());
    }
    std::this_thread::sleep_for(100ms);
  }
}

// Paper mode: the members are other processes, found by name.
std::unique_ptr<rtm::RemoteComposite> make_remote_servo(const ServoOptions& o, const rtm::RunContext& context) {
  const rtm::NamingClient naming(context.orb.orb(), context.settings.naming);
  std::vector<rtm::RemoteComposite::Member> members;
  for (const auto& name : {o.sensor, o.controller, o.actuator})
    members.push_back({name, wait_for_component(naming, name, o.wait_s)});
  const std::int64_t phase_offset_ns = o.phase_offset_us < 0 ? context.settings.period_ns / 4
                                                             : static_cast<std::int64_t>(o.phase_offset_us * 1000);
  return std::make_unique<rtm::RemoteComposite>(
      context.settings.name, "servo",
      rtm::comp::servo_diagram(context.settings.name, o.sensor, o.controller, o.actuator, false, phase_offset_ns),
      std::move(members));
}

// Shared-tick mode: the members live here, on the arm's bus, run by one tick.
std::unique_ptr<rtm::TickedComposite> make_shared_tick_servo(ServoOptions& o, const rtm::RunContext& context) {
  const rtm::RunSettings& settings = context.settings;
  o.hardware.period_ns = settings.period_ns;
  o.hardware.rt_priority = settings.rt_priority;
  o.hardware.cpu = settings.cpu;
  auto arm = std::make_unique<rtm::pa10::ArmHardware>(o.hardware);
  rtm::can::Pa10Master* master = &arm->master();  // owned by the actuator, outlives the tick
  rtm::TickPhase phase;
  rtm::TickStage* bus = nullptr;  // the master's SYNC cycle, a stage of the tick
  if (o.bus_cycle == "tick") {
    bus = master;
  } else {
    phase.next_reference_deadline_ns = [master] { return master->next_cycle_deadline_ns(); };
    phase.lead_ns = static_cast<std::int64_t>(o.tick_lead_us * 1000);
  }
  std::vector<std::unique_ptr<rtm::Component>> members;
  members.push_back(rtm::comp::Sensor::wrist(
      o.sensor, std::make_unique<rtm::comp::MasterForceSource>(*master, rtm::can::ForceSensor::wrist),
      rtm::pa10::Kinematics::pa10(o.hardware.urdf)));
  members.push_back(std::make_unique<rtm::comp::Controller>(o.controller, o.controller_params));
  members.push_back(std::make_unique<rtm::comp::Actuator>(o.actuator, std::move(arm), o.actuator_params));
  auto servo = std::make_unique<rtm::TickedComposite>(
      settings.name, "servo", rtm::comp::servo_diagram(settings.name, o.sensor, o.controller, o.actuator, true),
      std::move(members), settings.periodic_options(), std::move(phase), bus);
  servo->activate_members(context.orb);
  if (settings.watch_contract) {
    // Each member's cycle against its own budget and the tick's deadline (rtm ls -l on the
    // member's name); the tick is the members' activity, so they share its class and CPU.
    for (const auto& [name, budget_ns] : {std::pair{o.sensor, rtm::comp::kWristSensorBudgetNs},
                                          std::pair{o.controller, rtm::comp::kControllerBudgetNs},
                                          std::pair{o.actuator, rtm::comp::kActuatorBudgetNs}}) {
      rtm::TimingContract contract = settings.contract();
      contract.component = name;
      contract.budget_ns = budget_ns;
      servo->member(name).watch_contract(contract);
    }
  }
  return servo;
}

// The program, and the module rtm-container loads: each servo made has its own options.
rtm::ComponentMain servo() {
  struct State {
    ServoOptions options;
    rtm::TickedComposite* shared = nullptr;  // owned by the servant, in shared-tick mode
    RTM::InPort_var reference;               // the controller's InPort "reference"
  };
  auto state = std::make_shared<State>();
  return {
      .kind = "servo",
      .description = "rtm-servo: force-servo composite (Figs. 4, 8): sensor -> controller -> actuator; in0 = the "
                     "controller's reference InPort (TimedFloat6 wrench, base frame)",
      .add_options = [state](CLI::App& app) { state->options.add_options(app); },
      .validate = [state](const rtm::RunSettings&) { state->options.validate(); },
      .create_with_orb =
          [state](const rtm::RunContext& context) -> std::unique_ptr<rtm::Component> {
            auto& [options, shared, reference] = *state;
            const rtm::PortRef reference_port{options.controller, rtm::comp::kServoReferencePort};
            if (!options.shared_tick) {
              auto servo = make_remote_servo(options, context);
              reference = servo->in_port(reference_port);
              return servo;
            }
            auto servo = make_shared_tick_servo(options, context);
            shared = servo.get();
            reference = servo->in_port(reference_port);
            return servo;
          },
      .activity = [](const rtm::RunSettings&, rtm::Component&) { return rtm::ActivitySpec{rtm::ExternalTick{}}; },
      .on_activated =
          [state](rtm::ComponentServant& servant, const rtm::RunContext&) {
            auto& [options, shared, reference] = *state;
            servant.expose_in_port(0, reference);  // the servant keeps its own duplicate
            reference = RTM::InPort::_nil();          // none outlives the ORB
            std::vector<rtm::ExtraName> members;
            if (shared == nullptr) return members;
            servant.set_timing_source(&shared->tick());
            shared->add_to_tick(servant.cycle_function());
            for (auto* member : shared->members()) members.push_back({member->component().name(), member->reference()});
            return members;
          },
      .members =
          [state] {
            std::vector<rtm::ComponentServant*> members;
            if (state->shared != nullptr) members = state->shared->members();
            return members;
          },
      .has_contract = false,  // its members' loops, or its tick, keep theirs
      .pin_process_to_cpu = false,
  };
}

}  // namespace

RTM_COMPONENT(servo)
