// rtm-servo: the force-servo composite (paper Figs. 4, 8).
//
// Paper mode (default): --sensor/--controller/--actuator name RT components found through the
// naming service (waited for up to --wait); on() wires sensor.out0 -> controller.in0 and
// controller.out0 -> actuator.in0 and turns them on; off() reverses it.
// Shared-tick mode (--shared-tick): the three members are created in this process on the
// arm's bus (--bus, --sensor-bus) and run by one periodic tick, sensor -> controller ->
// actuator in that order; they are also bound by those names, for browsing.
// In both modes the servo's InPort 0 is the controller's InPort 1 (the reference).
//
// The component runner (rtm/runner.h) builds one servant from a component and offers no hook
// to the servant, which expose_in_port() needs; so this main follows the runner's sequence
// itself: parse, ORB, servants, names, sigwait, ordered shutdown.
#include "components/servo/servo.h"

#include "rtm/data.h"
#include "rtm/log.h"
#include "rtm/naming.h"
#include "rtm/orb.h"
#include "rtm/runner.h"

#include <CLI/CLI.hpp>
#include <signal.h>
#include <spdlog/logger.h>

#include <chrono>
#include <cstdio>
#include <optional>
#include <thread>
#include <vector>

namespace {

using namespace std::chrono_literals;

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

}  // namespace

int main(int argc, char** argv) {
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);  // before any thread: taken by sigwait only
  ::signal(SIGPIPE, SIG_IGN);

  auto split = rtm::split_orb_arguments(argc, argv);
  rtm::RunSettings settings;
  settings.name = "servo0";
  settings.orb_args = std::move(split.orb);
  std::string naming_text;
  std::string period_text = "2ms";
  bool shared_tick = false;
  double tick_lead_us = 100;  // > the tick's lateness p99 (40-60 us) + its cycle (~25 us)
  double wait_s = 10;
  std::string sensor_name = "sensor0", controller_name = "controller0", actuator_name = "actuator0";
  rtm::comp::ArmHardware::Options hardware;
  hardware.urdf = RTM_PA10_URDF;
  rtm::comp::ControllerParams controller_params;
  rtm::comp::ActuatorParams actuator_params;
  std::vector<float> gain(controller_params.gain.begin(), controller_params.gain.end());
  std::vector<float> limit(actuator_params.limit.begin(), actuator_params.limit.end());

  CLI::App app(
      "rtm-servo: force-servo composite (Figs. 4, 8): sensor -> controller -> actuator; in0 = the "
      "controller's reference InPort (TimedFloat6 wrench, base frame)",
      "rtm-servo");
  app.add_option("--name", settings.name, "component name, bound as <host>.host_cxt/<name>.rtc")->capture_default_str();
  app.add_option("--naming", naming_text, "naming service host:port")
      ->default_str(rtm::NamingAddress::from_environment().to_string())
      ->envname("RTM_NAMING");
  app.add_option("--period", period_text, "shared tick period: 2ms, 500us, 0.002s")->capture_default_str();
  app.add_option("--rt-priority", settings.rt_priority, "SCHED_FIFO priority of the tick and master (1..99)")
      ->check(CLI::Range(0, 99));
  app.add_option("--cpu", settings.cpu, "pin the tick and the master thread to this CPU")->check(CLI::NonNegativeNumber);
  app.add_option("--endpoint", settings.endpoints, "omniORB endpoint, repeatable (default: giop:tcp:127.0.0.1: and giop:unix:)");
  app.add_flag("--on", settings.turn_on, "turn the servo on once it is up");
  app.add_option("--sensor", sensor_name, "sensor member name (shared tick: the name it is bound as)")->capture_default_str();
  app.add_option("--controller", controller_name, "controller member name")->capture_default_str();
  app.add_option("--actuator", actuator_name, "actuator member name")->capture_default_str();
  app.add_option("--wait", wait_s, "paper mode: seconds to wait for the members to appear")->capture_default_str();
  double phase_offset_us = -1;
  app.add_option("--phase-offset-us", phase_offset_us,
                 "paper mode: turn members on sensor, controller, actuator this far apart (µs) so each cycle "
                 "finds its input fresh; 0 = downstream first; default: a quarter of --period")
      ->check(CLI::Range(-1.0, 1e6));
  app.add_flag("--shared-tick", shared_tick, "run the members in this process on one periodic tick");
  auto* group = app.add_option_group("shared tick", "members made by --shared-tick");
  std::string bus_cycle = "tick";
  group->add_option("--bus-cycle", bus_cycle,
                    "who runs the CAN master's SYNC cycle: 'tick' (the tick itself: receive, sensor -> controller -> "
                    "actuator, transmit; a sample reaches the drives in the same cycle) or 'master' (its own thread; "
                    "the tick runs --tick-lead-us before it)")
      ->check(CLI::IsMember({"tick", "master"}))
      ->capture_default_str();
  auto* lead_option =
      group->add_option("--tick-lead-us", tick_lead_us,
                        "--bus-cycle master: the tick's cycles fall this long before the master's SYNC cycles, so a "
                        "command leaves with the next SYNC (0 <= lead < --period)")
          ->capture_default_str();
  group->add_option("--bus", hardware.bus, "the arm's CAN bus: local:<path> or socketcan:<if>")->capture_default_str();
  group->add_option("--sensor-bus", hardware.sensor_bus, "separate bus of the force sensors (default: --bus)");
  group->add_option("--urdf", hardware.urdf, "arm model")->capture_default_str();
  group->add_option("--gain", gain, "controller: 6 gains, x y z (m/s)/N, rx ry rz (rad/s)/(N·m)")
      ->expected(6)
      ->capture_default_str();
  group->add_option("--stale-periods", controller_params.stale_periods, "controller: cycles before an input is stale")
      ->capture_default_str();
  group->add_option("--limit", limit, "actuator: 6 limits, vx vy vz m/s, wx wy wz rad/s")->expected(6)->capture_default_str();
  group->add_option("--watchdog-periods", actuator_params.watchdog_periods, "actuator: cycles without a command before zero")
      ->capture_default_str();
  app.footer("Options -ORB<name> <value> go to omniORB unchanged.");
  for (auto* option : app.get_options()) {
    if (option->get_expected_max() == 1) option->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
  }

  std::vector<const char*> own_argv;
  for (const auto& arg : split.own) own_argv.push_back(arg.c_str());
  try {
    app.parse(static_cast<int>(own_argv.size()), own_argv.data());
    if (lead_option->count() > 0 && bus_cycle != "master")
      throw CLI::ValidationError("--tick-lead-us", "applies to --bus-cycle master only");
    settings.period_ns = rtm::parse_period_ns(period_text);
    settings.naming = naming_text.empty() ? rtm::NamingAddress::from_environment() : rtm::NamingAddress::parse(naming_text);
    for (std::size_t i = 0; i < 6; ++i) {
      controller_params.gain[i] = gain[i];
      actuator_params.limit[i] = limit[i];
    }
    controller_params.validate();
    actuator_params.validate();
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "rtm-servo: %s\n", e.what());
    return 2;
  }
  if (settings.endpoints.empty()) settings.endpoints = {"giop:tcp:127.0.0.1:", "giop:unix:"};

  std::vector<std::string> orb_args;
  for (const auto& endpoint : settings.endpoints) orb_args.insert(orb_args.end(), {"-ORBendPoint", endpoint});
  orb_args.insert(orb_args.end(), settings.orb_args.begin(), settings.orb_args.end());
  std::optional<rtm::Orb> orb;
  try {
    orb.emplace(orb_args);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rtm-servo: %s\n", e.what());
    return 1;
  }

  int status = 0;
  {
    PortableServer::Servant_var<rtm::ComponentServant> servant;
    rtm::comp::SharedTickServo* shared = nullptr;
    std::vector<std::unique_ptr<rtm::NameBinding>> bindings;
    try {
      std::unique_ptr<rtm::Component> component;
      RTM::InPort_var reference;
      if (shared_tick) {
        hardware.period = std::chrono::nanoseconds(settings.period_ns);
        hardware.rt_priority = settings.rt_priority;
        hardware.cpu = settings.cpu;
        auto arm = std::make_unique<rtm::comp::ArmHardware>(hardware);
        rtm::can::Pa10Master* master = &arm->master();  // owned by the actuator, outlives the tick
        rtm::comp::TickPhase phase;
        rtm::comp::TickBusCycle bus;
        if (bus_cycle == "tick") {
          bus.take_over = [master] { return master->take_over_cycles(); };
          bus.hand_back = [master](std::int64_t next_ns) { master->hand_back_cycles(next_ns); };
          bus.receive = [master] { return master->receive_cycle(); };
          bus.transmit = [master] { return master->transmit_cycle(); };
        } else {
          phase.next_reference_deadline_ns = [master] { return master->next_cycle_deadline_ns(); };
          phase.lead_ns = static_cast<std::int64_t>(tick_lead_us * 1000);
        }
        auto sensor = std::make_unique<rtm::comp::Sensor>(
            sensor_name, std::make_unique<rtm::comp::MasterWristSource>(arm->master()),
            rtm::pa10::Kinematics::fromUrdfFile(hardware.urdf));
        auto controller = std::make_unique<rtm::comp::Controller>(controller_name, controller_params);
        auto actuator = std::make_unique<rtm::comp::Actuator>(actuator_name, std::move(arm), actuator_params);
        auto servo = std::make_unique<rtm::comp::SharedTickServo>(settings.name, std::move(sensor),
                                                                  std::move(controller), std::move(actuator),
                                                                  settings.periodic_options(), std::move(phase),
                                                                  std::move(bus));
        shared = servo.get();
        shared->activate_members(*orb);
        reference = shared->reference_port();
        component = std::move(servo);
      } else {
        const rtm::NamingClient naming(orb->orb(), settings.naming);
        auto sensor = wait_for_component(naming, sensor_name, wait_s);
        auto controller = wait_for_component(naming, controller_name, wait_s);
        auto actuator = wait_for_component(naming, actuator_name, wait_s);
        const auto phase_offset = phase_offset_us < 0
                                      ? std::chrono::nanoseconds(settings.period_ns / 4)
                                      : std::chrono::nanoseconds(static_cast<std::int64_t>(phase_offset_us * 1000));
        auto servo =
            std::make_unique<rtm::comp::RemoteServo>(settings.name, sensor, controller, actuator, phase_offset);
        reference = servo->reference_port();
        component = std::move(servo);
      }
      servant = new rtm::ComponentServant(std::move(component), rtm::ExternalTick{});
      if (shared != nullptr) {
        servant->set_timing_source(&shared->tick());
        shared->add_to_tick(servant->cycle_function());
      }
      RTM::RtComponentEx_var ref = servant->activate(*orb);
      servant->expose_in_port(0, reference);
      bindings.push_back(std::make_unique<rtm::NameBinding>(orb->orb(), settings.naming,
                                                            rtm::ComponentPath::on_this_host(settings.name), ref));
      if (shared != nullptr) {
        for (auto* member : {&shared->sensor(), &shared->controller(), &shared->actuator()}) {
          RTM::RtComponentEx_var member_ref = member->reference();
          bindings.push_back(std::make_unique<rtm::NameBinding>(
              orb->orb(), settings.naming, rtm::ComponentPath::on_this_host(member->component().name()), member_ref));
        }
      }
      if (settings.turn_on) servant->on();
    } catch (const CORBA::Exception& e) {
      rtm::log().error("{} could not start: CORBA {}", settings.name, e._name());
      status = 1;
    } catch (const std::exception& e) {
      rtm::log().error("{} could not start: {}", settings.name, e.what());
      status = 1;
    }

    if (status == 0) {
      int received = 0;
      while (sigwait(&signals, &received) != 0) {
      }
      rtm::log().info("stopping {} ({})", settings.name, received == SIGINT ? "SIGINT" : "SIGTERM");
    }
    try {
      if (servant) servant->off();
    } catch (const CORBA::Exception& e) {
      rtm::log().warn("{}: off() raised {}", settings.name, e._name());
    }
    bindings.clear();
    if (servant) servant->deactivate();
    servant = nullptr;  // the members (and the arm) go with the servo component
  }
  orb.reset();
  return status;
}
