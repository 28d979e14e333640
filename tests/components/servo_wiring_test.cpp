// SPDX-License-Identifier: Apache-2.0
// The servo composite through real CORBA and a real omniNames: members found by name, on()
// subscribes and turns them on, the servo's InPort 0 is the controller's InPort "reference" (a
// put on it lands in the controller), data flows sensor -> controller -> actuator, off()
// undoes it all. The members live in this process as ExternalTick servants, so the test runs
// their cycles. The servo is its declaration (servo_diagram) run by the host's composites.
#include "components/actuator/actuator.h"
#include "components/controller/controller.h"
#include "components/sensor/sensor.h"
#include "components/servo/servo.h"

#include "component_test_support.h"
#include "host/remote_composite.h"
#include "host/ticked_composite.h"
#include "rtm/naming.h"
#include "rtm/orb.h"
#include "rtm_test/eventually.h"
#include "rtm_test/omni_names.h"
#include "rtm_test/fake_force_source.h"
#include "rtm_test/recording_arm.h"

#include <gtest/gtest.h>

#include <time.h>

#include <atomic>
#include <chrono>
#include <string>
#include <thread>
#include <vector>

namespace {

using comp_test::cycle;
using comp_test::float6;

rtm::Orb& test_orb() {
  static rtm::Orb orb;  // omniORB: one ORB per process
  return orb;
}

using rtm_test::FakeForceSource;

using rtm_test::RecordingArm;

// The servo of paper mode, as rtm-servo makes it: its declaration run by a RemoteComposite.
std::unique_ptr<rtm::RemoteComposite> remote_servo(const std::string& name, const std::string (&names)[3],
                                                   RTM::RtComponent_ptr sensor, RTM::RtComponent_ptr controller,
                                                   RTM::RtComponent_ptr actuator, std::int64_t phase_offset_ns = 0) {
  std::vector<rtm::RemoteComposite::Member> members;
  members.push_back({names[0], RTM::RtComponent::_duplicate(sensor)});
  members.push_back({names[1], RTM::RtComponent::_duplicate(controller)});
  members.push_back({names[2], RTM::RtComponent::_duplicate(actuator)});
  return std::make_unique<rtm::RemoteComposite>(
      name, "servo", rtm::comp::servo_diagram(name, names[0], names[1], names[2], false, phase_offset_ns),
      std::move(members));
}

class ServoWiringTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto source = std::make_unique<FakeForceSource>();
    source_ = source.get();
    // The ready pose: tool pointing down (sensor +z = base -z).
    source_->sample.q_rad = {0, 0.360534478941, 0, 1.828143726078, 0, 0.952914448571, 0};
    auto arm = std::make_unique<RecordingArm>();
    arm_ = arm.get();
    rtm::comp::ControllerParams gains;
    gains.gain = {1, 1, 1, 1, 1, 1};
    rtm::comp::ActuatorParams limits;
    limits.limit = {100, 100, 100, 100, 100, 100};
    sensor_ = new rtm::ComponentServant(rtm::comp::Sensor::wrist("sensor0", std::move(source), rtm::pa10::Kinematics::pa10()),
                                        rtm::ExternalTick{});
    controller_ = new rtm::ComponentServant(std::make_unique<rtm::comp::Controller>("controller0", gains), rtm::ExternalTick{});
    actuator_ = new rtm::ComponentServant(std::make_unique<rtm::comp::Actuator>("actuator0", std::move(arm), limits),
                                          rtm::ExternalTick{});
    const rtm::NamingClient naming(test_orb().orb(), rtm::NamingAddress::parse(names_.address()));
    for (auto* member : {sensor_.in(), controller_.in(), actuator_.in()}) {
      RTM::RtComponentEx_var ref = member->activate(test_orb());
      naming.bind(rtm::ComponentPath::on_this_host(member->component().name()), ref);
    }
    const std::string names[3] = {"sensor0", "controller0", "actuator0"};
    RTM::RtComponent_var refs[3];
    for (int i = 0; i < 3; ++i) refs[i] = naming.resolve_component(names[i]);
    auto servo = remote_servo("servo0", names, refs[0], refs[1], refs[2]);
    RTM::InPort_var reference = servo->in_port({"controller0", rtm::comp::kServoReferencePort});
    servo_ = new rtm::ComponentServant(std::move(servo), rtm::ExternalTick{});
    servo_ref_ = servo_->activate(test_orb());
    servo_->expose_in_port(0, reference);
  }
  void TearDown() override {
    for (auto* s : {servo_.in(), sensor_.in(), controller_.in(), actuator_.in()}) {
      s->off();
      s->deactivate();
    }
  }

  rtm::comp::Sensor& sensor() { return static_cast<rtm::comp::Sensor&>(sensor_->component()); }
  rtm::comp::Controller& controller() { return static_cast<rtm::comp::Controller&>(controller_->component()); }
  rtm::comp::Actuator& actuator() { return static_cast<rtm::comp::Actuator&>(actuator_->component()); }
  void run_members_once(std::uint64_t n) {
    sensor_->cycle_function()(cycle(n));
    controller_->cycle_function()(cycle(n));
    actuator_->cycle_function()(cycle(n));
  }

  rtm_test::OmniNames names_;
  FakeForceSource* source_ = nullptr;
  RecordingArm* arm_ = nullptr;
  PortableServer::Servant_var<rtm::ComponentServant> sensor_, controller_, actuator_, servo_;
  RTM::RtComponentEx_var servo_ref_;
};

TEST_F(ServoWiringTest, OnSubscribesSensorToControllerToActuatorAndTurnsEachOn) {
  EXPECT_EQ(sensor().out().subscription_count(), 0u);
  servo_ref_->on();
  EXPECT_EQ(servo_ref_->state(), RTM::COMPONENT_ON);
  for (auto* member : {sensor_.in(), controller_.in(), actuator_.in()})
    EXPECT_EQ(member->current_state(), RTM::COMPONENT_ON) << member->component().name();
  EXPECT_EQ(sensor().out().subscription_count(), 1u);
  EXPECT_EQ(controller().command_out().subscription_count(), 1u);
  RTM::SubscriptionInfoList_var subs = controller().command_out().subscriptions();
  ASSERT_EQ(subs->length(), 1u);
  EXPECT_EQ(subs[0].req_type, RTM::repeated);
}

TEST_F(ServoWiringTest, ServoInPortZeroIsTheControllersReferencePort) {
  RTM::InPortList_var servo_ins = servo_ref_->in_ports();
  ASSERT_EQ(servo_ins->length(), 1u);
  RTM::InPortEx_var controller_in1 = controller().reference_in().reference();
  EXPECT_TRUE(servo_ins[0]->_is_equivalent(controller_in1.in()));
  CORBA::Any any;
  any <<= float6({0, 0, -7, 0, 0, 0});
  servo_ins[0]->put(any);  // through the ORB, to the servo's port
  RTM::TimedFloat6 got{};
  ASSERT_EQ(controller().reference_in().read(got), rtm::ReadResult::NewData) << "the put landed in the controller";
  EXPECT_FLOAT_EQ(got.val[2], -7.0f);
}

TEST_F(ServoWiringTest, DataFlowsFromSensorThroughControllerToTheArm) {
  servo_ref_->on();
  RTM::InPortList_var servo_ins = servo_ref_->in_ports();
  CORBA::Any any;
  any <<= float6({0, 0, -10, 0, 0, 0});
  servo_ins[0]->put(any);
  source_->push({0, 0, 4, 0, 0, 0});  // sensor frame: tool down, so -4 N in base z
  run_members_once(0);
  ASSERT_FALSE(arm_->ordered.empty());
  EXPECT_NEAR(arm_->ordered.back()[2], 1.0 * (-10 + -4), 1e-3) << "gain * (ref + sen) reached the arm";
}

TEST_F(ServoWiringTest, OffTurnsTheMembersOffAndRemovesTheSubscriptions) {
  servo_ref_->on();
  servo_ref_->off();
  EXPECT_EQ(servo_ref_->state(), RTM::COMPONENT_OFF);
  for (auto* member : {sensor_.in(), controller_.in(), actuator_.in()})
    EXPECT_EQ(member->current_state(), RTM::COMPONENT_OFF) << member->component().name();
  EXPECT_EQ(sensor().out().subscription_count(), 0u);
  EXPECT_EQ(controller().command_out().subscription_count(), 0u);
  servo_ref_->on();  // and again: nothing was left behind that would refuse it
  EXPECT_EQ(servo_ref_->state(), RTM::COMPONENT_ON);
  EXPECT_EQ(sensor().out().subscription_count(), 1u);
}

TEST_F(ServoWiringTest, AMemberWithoutTheExpectedPortFailsOnNamingTheLinkAndTurnsNothingOn) {
  // A "sensor" with no OutPort: the wiring step must fail, say which link, and leave the
  // other members off and unsubscribed.
  class PortlessSensor final : public rtm::Component {
   public:
    PortlessSensor() : Component("sensor9", "sensor") {}
    void on_cycle(const rtm::CycleContext&) override {}
  };
  PortableServer::Servant_var<rtm::ComponentServant> portless =
      new rtm::ComponentServant(std::make_unique<PortlessSensor>(), rtm::ExternalTick{});
  RTM::RtComponentEx_var portless_ref = portless->activate(test_orb());
  RTM::RtComponentEx_var controller_ref = controller_->reference();
  RTM::RtComponentEx_var actuator_ref = actuator_->reference();
  auto servo = remote_servo("servo1", {"sensor9", "controller0", "actuator0"}, portless_ref, controller_ref,
                            actuator_ref);
  try {
    servo->on_start();
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("sensor9.wrench -> controller0.wrench: sensor9 has no OutPort wrench"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(controller().command_out().subscription_count(), 0u);
  EXPECT_EQ(actuator_->current_state(), RTM::COMPONENT_OFF);
  EXPECT_EQ(controller_->current_state(), RTM::COMPONENT_OFF);
  portless->deactivate();
}

// A member that records when it is turned on; ports named like those of the member it stands
// for (in: the InPorts' names, out: the OutPort's).
class OrderProbe final : public rtm::Component {
 public:
  OrderProbe(std::string name, std::vector<std::string>& turned_on, std::vector<std::string> in = {"wrench", "twist"},
             const std::string& out = "wrench")
      : Component(std::move(name), "probe"), turned_on_(turned_on) {
    for (const auto& port : in) add_in_port<RTM::TimedFloat6>(port);
    add_out_port<RTM::TimedFloat6>(out);
  }
  void on_start() override { turned_on_.push_back(name()); }
  void on_cycle(const rtm::CycleContext&) override {}

 private:
  std::vector<std::string>& turned_on_;
};

std::vector<std::string> order_of_on(std::chrono::nanoseconds phase_offset) {
  std::vector<std::string> turned_on;
  PortableServer::Servant_var<rtm::ComponentServant> members[3];
  RTM::RtComponentEx_var refs[3];
  const char* names[3] = {"probe_sensor", "probe_controller", "probe_actuator"};
  const std::vector<std::string> ins[3] = {{}, {"wrench", "reference"}, {"twist"}};
  const char* outs[3] = {"wrench", "twist", "state"};
  for (int i = 0; i < 3; ++i) {
    members[i] = new rtm::ComponentServant(std::make_unique<OrderProbe>(names[i], turned_on, ins[i], outs[i]),
                                           rtm::ExternalTick{});
    refs[i] = members[i]->activate(test_orb());
  }
  auto servo = remote_servo("servo_order", {names[0], names[1], names[2]}, refs[0], refs[1], refs[2],
                            phase_offset.count());
  servo->on_start();
  servo->on_stop();
  for (auto& member : members) member->deactivate();
  return turned_on;
}

TEST(RemoteServoOrder, WithAPhaseOffsetMembersTurnOnUpstreamFirstWithoutDownstreamFirst) {
  using namespace std::chrono_literals;
  const std::vector<std::string> upstream_first{"probe_sensor", "probe_controller", "probe_actuator"};
  const std::vector<std::string> downstream_first{"probe_actuator", "probe_controller", "probe_sensor"};
  EXPECT_EQ(order_of_on(500us), upstream_first);
  EXPECT_EQ(order_of_on(0ns), downstream_first);
}

TEST(RemoteServoOrder, ANegativePhaseOffsetIsRefused) {
  PortableServer::Servant_var<rtm::ComponentServant> probe;
  std::vector<std::string> turned_on;
  probe = new rtm::ComponentServant(std::make_unique<OrderProbe>("probe_x", turned_on), rtm::ExternalTick{});
  RTM::RtComponentEx_var ref = probe->activate(test_orb());
  EXPECT_THROW(remote_servo("servo_bad", {"a", "b", "c"}, ref, ref, ref, -1), rtm::DiagramError);
  probe->deactivate();
}

TEST(SharedTickPhase, TheTickStartsTheLeadBeforeTheBusMastersNextCycle) {
  constexpr std::int64_t kPeriod_ns = 2'000'000;
  const std::int64_t master_next_ns = 1'000 * kPeriod_ns + 456'789;
  const std::int64_t first = rtm::phased_first_deadline(master_next_ns, 300'000, kPeriod_ns);
  EXPECT_EQ(first, master_next_ns - 300'000);
  // Whichever cycle the tick actually starts on, it stays on that grid (first_deadline()).
  const std::int64_t now = master_next_ns + 3 * kPeriod_ns;
  const std::int64_t started = rtm::first_deadline(first, kPeriod_ns, now);
  EXPECT_GE(started, now);
  EXPECT_LT(started, now + kPeriod_ns);
  EXPECT_EQ(((started + 300'000) - master_next_ns) % kPeriod_ns, 0) << "the lead holds for every later cycle";
}

TEST(SharedTickPhase, WithoutAReferenceTheTickStartsAtOnce) {
  EXPECT_EQ(rtm::phased_first_deadline(0, 300'000, 2'000'000), 0);
}

TEST(SharedTickPhase, ALeadOfAPeriodOrMoreOrNegativeIsRefused) {
  EXPECT_THROW(rtm::phased_first_deadline(5'000'000, 2'000'000, 2'000'000), std::invalid_argument);
  EXPECT_THROW(rtm::phased_first_deadline(5'000'000, -1, 2'000'000), std::invalid_argument);
  EXPECT_EQ(rtm::phased_first_deadline(5'000'000, 0, 2'000'000), 5'000'000);
}

// ---- the shared tick running the bus master's cycle -------------------------------------

// The bus cycle and the arm write into one log, so the order of receive, the actuator's
// command and transmit within each tick is visible. Written on the tick's thread, read after
// on_stop() has joined it.
struct BusLog final : rtm::TickStage {
  std::vector<std::string> events;
  std::vector<std::int64_t> hand_backs;
  std::int64_t take_over_ns = 0;
  std::int64_t first_receive_ns = 0;
  int fail_on_order = -1;  // the arm throws on this order (0-based); -1 never
  int orders = 0;
  std::atomic<int> transmits{0};
  std::atomic<bool> bus_lost{false};  // the bus master has taken its cycles back
  std::atomic<int> take_overs{0};
  std::vector<std::int64_t> take_over_called_ns;  // when each take_over() was called
  std::vector<std::int64_t> transmit_ns;          // when each transmit the bus took ran

  // The bus cycle as a stage of the tick, each call logged.
  std::int64_t take_over() override;
  void hand_back(std::int64_t next_ns) override {
    events.push_back("hand_back");
    hand_backs.push_back(next_ns);
  }
  bool receive(std::int64_t) override;
  bool transmit(std::int64_t) override;
};

// The arm of a servo under test: each order is logged, and one of them throws (the drives' bus gone).
std::unique_ptr<RecordingArm> logging_arm(BusLog& log) {
  auto arm = std::make_unique<RecordingArm>();
  arm->on_order = [&log] {
    if (log.orders++ == log.fail_on_order) throw std::runtime_error("drive bus gone");
    log.events.push_back("order");
  };
  return arm;
}

std::int64_t monotonic_ns() {
  timespec t{};
  clock_gettime(CLOCK_MONOTONIC, &t);
  return std::int64_t{t.tv_sec} * 1'000'000'000 + t.tv_nsec;
}

std::int64_t BusLog::take_over() {
  events.push_back("take_over");
  take_over_called_ns.push_back(monotonic_ns());
  bus_lost.store(false);  // the cycles are the caller's again
  take_overs.fetch_add(1);
  take_over_ns = monotonic_ns() + 20'000'000;  // the bus's next cycle: 20 ms from now
  return take_over_ns;
}

bool BusLog::receive(std::int64_t) {
  if (first_receive_ns == 0) first_receive_ns = monotonic_ns();
  events.push_back("receive");
  return !bus_lost.load();
}

bool BusLog::transmit(std::int64_t) {
  events.push_back("transmit");
  transmits.fetch_add(1);
  if (bus_lost.load()) return false;
  transmit_ns.push_back(monotonic_ns());
  return true;
}

std::unique_ptr<rtm::TickedComposite> make_shared_servo(const std::string& name, BusLog& log, rtm::TickStage* bus,
                                                       rtm::TickPhase phase = {}) {
  auto source = std::make_unique<FakeForceSource>();
  source->sample.q_rad = {0, 0.360534478941, 0, 1.828143726078, 0, 0.952914448571, 0};
  source->push({0, 0, 0, 0, 0, 0});
  rtm::comp::ControllerParams gains;
  rtm::comp::ActuatorParams limits;
  std::vector<std::unique_ptr<rtm::Component>> members;
  members.push_back(rtm::comp::Sensor::wrist(name + "_sensor", std::move(source), rtm::pa10::Kinematics::pa10()));
  members.push_back(std::make_unique<rtm::comp::Controller>(name + "_controller", gains));
  members.push_back(std::make_unique<rtm::comp::Actuator>(name + "_actuator", logging_arm(log), limits));
  return std::make_unique<rtm::TickedComposite>(
      name, "servo",
      rtm::comp::servo_diagram(name, name + "_sensor", name + "_controller", name + "_actuator", true),
      std::move(members), rtm::PeriodicOptions{}, std::move(phase), bus);
}

// As rtm-servo runs it: a shared-tick servo on the logging bus whose own servant runs last in
// the tick and reports its members; activated.
struct ServoInTick {
  rtm::TickedComposite* shared = nullptr;
  PortableServer::Servant_var<rtm::ComponentServant> servo;
  RTM::RtComponentEx_var ref;
  ServoInTick(const std::string& name, BusLog& log) {
    auto component = make_shared_servo(name, log, &log);
    shared = component.get();
    shared->activate_members(test_orb());
    servo = new rtm::ComponentServant(std::move(component), rtm::ExternalTick{});
    servo->set_timing_source(&shared->tick());
    shared->add_to_tick(servo->cycle_function());
    ref = servo->activate(test_orb());
  }
};

void wait_for_transmits(BusLog& log, int n) {
  rtm_test::eventually([&] { return log.transmits.load() >= n; });
}

TEST(SharedTickBusCycle, EachTickReceivesThenCommandsThenTransmitsFromTheDeadlineTakenOver) {
  BusLog log;
  auto servo = make_shared_servo("servo_bus", log, &log);
  servo->activate_members(test_orb());
  ASSERT_TRUE(servo->runs_stage());
  servo->on_start();
  wait_for_transmits(log, 10);
  servo->on_stop();

  ASSERT_GE(log.events.size(), 4u);
  EXPECT_EQ(log.events.front(), "take_over");
  EXPECT_EQ(log.events.back(), "hand_back");
  EXPECT_GE(log.first_receive_ns, log.take_over_ns) << "the tick's first cycle is the bus's next one, not earlier";
  // Between take-over and hand-back: receive, order, transmit, again and again.
  int transmits = 0;
  for (std::size_t i = 1; i + 1 < log.events.size(); i += 3) {
    ASSERT_LE(i + 2, log.events.size() - 1) << "a tick cut short";
    EXPECT_EQ(log.events[i], "receive") << "event " << i;
    EXPECT_EQ(log.events[i + 1], "order") << "event " << i + 1;
    EXPECT_EQ(log.events[i + 2], "transmit") << "event " << i + 2;
    ++transmits;
  }
  EXPECT_GE(transmits, 10);
  // Handed back once, due one period after a tick on the grid taken over.
  ASSERT_EQ(log.hand_backs.size(), 1u);
  const std::int64_t period_ns = servo->tick().options().period_ns;
  EXPECT_EQ((log.hand_backs[0] - log.take_over_ns) % period_ns, 0);
  EXPECT_GE(log.hand_backs[0], log.take_over_ns + transmits * period_ns);
  EXPECT_EQ(servo->member("servo_bus_actuator").current_state(), RTM::COMPONENT_OFF);
}

TEST(SharedTickBusCycle, AFailingActuatorPutsTheServoInErrorAndHandsTheBusBackAfterItsZeroCommandLeft) {
  BusLog log;
  log.fail_on_order = 4;
  ServoInTick in_tick("servo_fail", log);
  rtm::TickedComposite* shared = in_tick.shared;
  rtm::ComponentServant* servo = in_tick.servo.in();
  servo->on();
  // Each half is checked below.
  rtm_test::eventually(
      [&] { return servo->current_state() == RTM::COMPONENT_ERROR && !shared->tick().running(); });
  ASSERT_EQ(servo->current_state(), RTM::COMPONENT_ERROR) << "the servo must not stay on with a failed member";
  EXPECT_NE(servo->error_text().find("servo_fail_actuator failed"), std::string::npos) << servo->error_text();
  EXPECT_FALSE(shared->tick().running());
  EXPECT_EQ(shared->member("servo_fail_actuator").current_state(), RTM::COMPONENT_ERROR);
  // The failing cycle still transmits (the actuator's on_stop set zero), then the cycles go
  // back once, due one period after that cycle: the drives miss no SYNC.
  EXPECT_EQ(log.transmits.load(), 5);
  ASSERT_EQ(log.hand_backs.size(), 1u);
  const std::int64_t period_ns = shared->tick().options().period_ns;
  EXPECT_EQ((log.hand_backs[0] - log.take_over_ns) % period_ns, 0);
  EXPECT_GE(log.hand_backs[0], log.take_over_ns + 5 * period_ns);
  ASSERT_GE(log.events.size(), 3u);
  EXPECT_EQ(log.events[log.events.size() - 3], "receive") << "the failing cycle ordered nothing";
  EXPECT_EQ(log.events[log.events.size() - 2], "transmit");
  EXPECT_EQ(log.events.back(), "hand_back");
  servo->off();
  EXPECT_EQ(log.hand_backs.size(), 1u) << "handed back twice";
  servo->deactivate();
}

// A stall made the bus master take its cycles back (receive and transmit refused). The tick,
// running again, takes them again (the servo's own cycle, run last in the tick as rtm-servo
// runs it): from the deadline the master returns, skipping the bus halves of its cycles before
// it (no period carries two SYNCs), and the servo stays on.
TEST(SharedTickBusCycle, CyclesTakenBackByTheBusMasterAreTakenAgainFromTheDeadlineItReturns) {
  BusLog log;
  ServoInTick in_tick("servo_lost", log);
  rtm::ComponentServant* servo = in_tick.servo.in();
  servo->on();
  wait_for_transmits(log, 3);
  log.bus_lost.store(true);
  ASSERT_TRUE(rtm_test::eventually([&] { return log.take_overs.load() >= 2; }));
  ASSERT_EQ(log.take_overs.load(), 2) << "the cycles were not taken again";
  // The fake's next cycle is 20 ms after the retake: the transmits counted from here on come
  // after it.
  wait_for_transmits(log, log.transmits.load() + 3);
  EXPECT_EQ(servo->current_state(), RTM::COMPONENT_ON) << "a stall is survived: " << servo->error_text();
  servo->off();
  EXPECT_EQ(log.take_overs.load(), 2) << "taken again once";
  ASSERT_EQ(log.take_over_called_ns.size(), 2u);
  const std::int64_t retaken_ns = log.take_over_called_ns[1];
  const std::int64_t resume_ns = log.take_over_ns;
  int after_resume = 0;
  for (const std::int64_t t : log.transmit_ns) {
    EXPECT_FALSE(t > retaken_ns && t < resume_ns) << "a transmit " << (resume_ns - t) / 1000
                                                  << " us before the deadline the master returned";
    if (t >= resume_ns) ++after_resume;
  }
  EXPECT_GE(after_resume, 3) << "the tick runs the bus cycles again";
  ASSERT_EQ(log.hand_backs.size(), 1u) << "the retaken cycles are handed back at the stop";
  EXPECT_GT(log.hand_backs[0], resume_ns);
  servo->deactivate();
}

TEST(SharedTickBusCycle, ABusCycleWithAPhaseReferenceIsRefused) {
  BusLog log;
  rtm::TickPhase phase;
  phase.next_reference_deadline_ns = [] { return std::int64_t{0}; };
  EXPECT_THROW(make_shared_servo("servo_both", log, &log, phase), std::invalid_argument);
  EXPECT_FALSE(make_shared_servo("servo_plain", log, nullptr)->runs_stage());
}

}  // namespace
