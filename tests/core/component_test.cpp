// SPDX-License-Identifier: Apache-2.0
#include "core_test_support.h"

#include "rt/clock.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <ctime>
#include <string>
#include <thread>

namespace {

using rtm::ReadResult;
using rtm::test::Doubler;
using rtm::test::eventually;
using rtm::test::float6;

class ComponentTest : public rtm::test::OrbTest {};

using rtm::test::fast;

TEST(Component, LogicRunsWithoutAnOrb) {
  Doubler d;
  EXPECT_EQ(d.name(), "doubler0");
  EXPECT_EQ(d.kind(), "controller");
  ASSERT_EQ(d.in_ports().size(), 1u);
  ASSERT_EQ(d.out_ports().size(), 1u);
  EXPECT_EQ(d.in_ports()[0]->full_name(), "doubler0.in0");
  d.in.deliver(float6(1.0f));
  d.on_cycle(rtm::CycleContext{});
  RTM::TimedFloat6 out{};
  ASSERT_TRUE(d.out.latest(out));
  EXPECT_FLOAT_EQ(out.val[0], 2.0f);
  EXPECT_FLOAT_EQ(out.val[5], 12.0f);
}

TEST_F(ComponentTest, PortsAreListedInDeclarationOrderThroughTheOrb) {
  class TwoByTwo final : public rtm::Component {
   public:
    TwoByTwo() : Component("ctrl0", "controller") {
      add_in_port<RTM::TimedFloat6>("sensor");
      add_in_port<RTM::TimedFloat6>("reference");
      add_out_port<RTM::TimedFloat6>("velocity");
      add_out_port<RTM::TimedDouble>("effort");
    }
    void on_cycle(const rtm::CycleContext&) override {}
  };
  rtm::ComponentServant servant(std::make_unique<TwoByTwo>(), fast());
  RTM::RtComponentEx_var ref = servant.activate(orb());
  CORBA::String_var name = ref->name();
  CORBA::String_var kind = ref->kind();
  EXPECT_STREQ(name.in(), "ctrl0");
  EXPECT_STREQ(kind.in(), "controller");
  RTM::InPortList_var ins = ref->in_ports();
  RTM::OutPortList_var outs = ref->out_ports();
  ASSERT_EQ(ins->length(), 2u);
  ASSERT_EQ(outs->length(), 2u);
  CORBA::String_var in0 = ins[0]->name();
  CORBA::String_var in1 = ins[1]->name();
  CORBA::String_var out1 = outs[1]->name();
  EXPECT_STREQ(in0.in(), "sensor");
  EXPECT_STREQ(in1.in(), "reference");
  EXPECT_STREQ(out1.in(), "effort");
  CORBA::TypeCode_var effort_type = outs[1]->port_type();
  EXPECT_TRUE(effort_type->equivalent(RTM::_tc_TimedDouble));
}

TEST_F(ComponentTest, OnAndOffAreIdempotentAndOffWaitsForTheActivity) {
  auto logic = std::make_unique<Doubler>();
  Doubler& d = *logic;
  rtm::ComponentServant servant(std::move(logic), fast());
  RTM::RtComponentEx_var ref = servant.activate(orb());
  EXPECT_EQ(ref->state(), RTM::COMPONENT_OFF);
  for (int round = 1; round <= 3; ++round) {
    ref->on();
    ref->on();
    EXPECT_EQ(ref->state(), RTM::COMPONENT_ON);
    const long before = d.cycles.load();
    ASSERT_TRUE(eventually([&] { return d.cycles.load() > before + 2; }));
    ref->off();
    ref->off();
    EXPECT_EQ(ref->state(), RTM::COMPONENT_OFF);
    const long after = d.cycles.load();
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    EXPECT_EQ(d.cycles.load(), after);
    EXPECT_EQ(d.starts.load(), round);
    EXPECT_EQ(d.stops.load(), round);
  }
  const RTM::TimingStats timing = ref->timing();
  EXPECT_EQ(timing.period_ns, 1'000'000u);
  EXPECT_EQ(timing.cycles, static_cast<CORBA::ULongLong>(d.cycles.load()));
}

TEST_F(ComponentTest, ThrowingCycleMovesToErrorUntilReset) {
  auto logic = std::make_unique<Doubler>();
  Doubler& d = *logic;
  d.throw_at_cycle = 3;
  rtm::ComponentServant servant(std::move(logic), fast());
  RTM::RtComponentEx_var ref = servant.activate(orb());
  ref->on();
  ASSERT_TRUE(eventually([&] { return ref->state() == RTM::COMPONENT_ERROR; }));
  CORBA::String_var why = ref->last_error();
  EXPECT_NE(std::string(why.in()).find("injected failure in cycle 3"), std::string::npos) << why.in();
  // on_stop() follows the error; then no cycle more for a while.
  ASSERT_TRUE(eventually([&] { return d.stops.load() >= 1; }));
  std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_EQ(d.cycles.load(), 3);  // the activity stopped with the failing cycle
  EXPECT_EQ(d.stops.load(), 1);   // and the component was told to stop acting
  try {
    ref->on();
    FAIL() << "on() in COMPONENT_ERROR did not raise";
  } catch (const CORBA::BAD_INV_ORDER& e) {
    EXPECT_EQ(e.minor(), rtm::kMinorComponentError);
  }
  ref->reset();
  EXPECT_EQ(ref->state(), RTM::COMPONENT_OFF);
  CORBA::String_var cleared = ref->last_error();
  EXPECT_STREQ(cleared.in(), "");
  ref->on();
  ASSERT_TRUE(eventually([&] { return d.cycles.load() > 5; }));
  EXPECT_EQ(ref->state(), RTM::COMPONENT_ON);
  ref->off();
}

TEST_F(ComponentTest, ThrowingOnStartRaisesAndMovesToError) {
  auto logic = std::make_unique<Doubler>();
  Doubler& d = *logic;
  d.throw_on_start = true;
  rtm::ComponentServant servant(std::move(logic), fast());
  RTM::RtComponentEx_var ref = servant.activate(orb());
  EXPECT_THROW(ref->on(), CORBA::BAD_INV_ORDER);
  EXPECT_EQ(ref->state(), RTM::COMPONENT_ERROR);
  CORBA::String_var why = ref->last_error();
  EXPECT_STREQ(why.in(), "on_start threw: injected failure in on_start");
  EXPECT_EQ(d.cycles.load(), 0);
  d.throw_on_start = false;
  ref->reset();
  ref->on();
  EXPECT_EQ(ref->state(), RTM::COMPONENT_ON);
  ref->off();
}

TEST_F(ComponentTest, OnArrivalComponentCyclesWhenDataIsPut) {
  auto logic = std::make_unique<Doubler>("doubler1");
  Doubler& d = *logic;
  rtm::ComponentServant servant(std::move(logic), rtm::OnArrival{0});
  RTM::RtComponentEx_var ref = servant.activate(orb());
  RTM::InPortList_var ins = ref->in_ports();
  ref->on();
  std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_EQ(d.cycles.load(), 0);
  CORBA::Any a;
  a <<= float6(3.0f);
  ins[0]->put(a);
  ASSERT_TRUE(eventually([&] { return d.cycles.load() >= 1; }));
  RTM::TimedFloat6 out{};
  ASSERT_TRUE(eventually([&] { return d.out.latest(out); }));
  EXPECT_FLOAT_EQ(out.val[0], 6.0f);
  ref->off();
}

double statistic(rtm::ComponentServant& servant, const std::string& name) {
  RTM::StatisticList_var stats = servant.statistics();
  for (CORBA::ULong i = 0; i < stats->length(); ++i)
    if (name == stats[i].name.in()) return stats[i].value;
  return -1;
}

// A counter declared once is the field the component counts, the statistic `rtm cat` reads
// (by its name, with its description) and the value a test reads.
struct Counting final : rtm::Component {
  struct Counters : rtm::CounterSet {
    rtm::Counter seen{*this, "seen", "data seen"};
    rtm::Counter dropped{*this, "dropped", "data dropped"};
  } counters;
  Counting() : Component("counting0", "controller") { add_counters(counters); }
  void on_cycle(const rtm::CycleContext&) override {}
};

TEST_F(ComponentTest, ACounterSetIsTheComponentsStatisticsInTheOrderDeclared) {
  auto* component = new Counting;
  auto& counters = component->counters;
  PortableServer::Servant_var<rtm::ComponentServant> servant =
      new rtm::ComponentServant(std::unique_ptr<rtm::Component>(component), fast());
  EXPECT_EQ(counters.seen.add(), 1u) << "add() returns the count after it";
  EXPECT_EQ(counters.seen.add(2), 3u);
  counters.dropped.add();
  EXPECT_EQ(counters.seen, 3u);
  EXPECT_EQ(statistic(*servant, "seen"), 3.0);
  EXPECT_EQ(statistic(*servant, "dropped"), 1.0);
  RTM::StatisticList_var stats = servant->statistics();
  std::vector<std::string> names, descriptions;
  for (CORBA::ULong i = 0; i < stats->length(); ++i) {
    names.emplace_back(stats[i].name.in());
    descriptions.emplace_back(stats[i].description.in());
  }
  const auto seen = std::find(names.begin(), names.end(), "seen");
  ASSERT_NE(seen, names.end());
  ASSERT_NE(seen + 1, names.end());
  EXPECT_EQ(*(seen + 1), "dropped");
  EXPECT_EQ(descriptions[seen - names.begin()], "data seen");
  EXPECT_EQ(std::count(names.begin(), names.end(), "seen"), 1);
}

// --await: each cycle first waits for its datum, bounded; a cycle whose datum came while it
// waited, and one whose datum did not come, are counted.
TEST_F(ComponentTest, ACycleAwaitingItsDatumCountsWhatCameWhileItWaitedAndWhatDidNot) {
  auto logic = std::make_unique<Doubler>();
  Doubler& d = *logic;
  rtm::ComponentServant servant(std::move(logic), fast());
  servant.await_before_cycle(d.in, 500'000);
  EXPECT_EQ(statistic(servant, "await.missed"), 0.0);
  servant.on();
  ASSERT_TRUE(eventually([&] { return statistic(servant, "await.missed") >= 3; })) << "nothing is written";
  EXPECT_EQ(statistic(servant, "await.arrived"), 0.0);
  std::atomic<bool> stop{false};
  std::thread feeder([&] {  // a datum each time a cycle is seen waiting for one
    while (!stop.load()) {
      if (d.in.awaiting() > 0) {
        d.in.deliver(float6(1.0f));
        while (!stop.load() && d.in.awaiting() > 0) std::this_thread::yield();
      }
      std::this_thread::sleep_for(std::chrono::microseconds(20));
    }
  });
  const bool arrived = eventually([&] { return statistic(servant, "await.arrived") >= 3; });
  stop = true;
  feeder.join();
  servant.off();
  EXPECT_TRUE(arrived);
}

TEST_F(ComponentTest, OnlyAPeriodicCycleAwaitsADatum) {
  auto logic = std::make_unique<Doubler>();
  Doubler& d = *logic;
  rtm::ComponentServant servant(std::move(logic), rtm::OnArrival{0});
  EXPECT_THROW(servant.await_before_cycle(d.in, 500'000), std::invalid_argument);
}

TEST_F(ComponentTest, OnArrivalNamingAMissingPortIsRefused) {
  EXPECT_THROW(rtm::ComponentServant(std::make_unique<Doubler>(), rtm::OnArrival{1}), std::invalid_argument);
}

TEST_F(ComponentTest, CompositeRunsChildrenOnOneTickAndHandsOutAChildsInPort) {
  // sensor-like source -> doubler -> doubler, all on one SharedTick; the composite's in port 0
  // is the first doubler's in0.
  auto first_logic = std::make_unique<Doubler>("first");
  auto second_logic = std::make_unique<Doubler>("second");
  Doubler& first = *first_logic;
  Doubler& second = *second_logic;
  rtm::ComponentServant first_servant(std::move(first_logic), rtm::ExternalTick{});
  rtm::ComponentServant second_servant(std::move(second_logic), rtm::ExternalTick{});
  RTM::RtComponentEx_var first_ref = first_servant.activate(orb());
  RTM::RtComponentEx_var second_ref = second_servant.activate(orb());
  ASSERT_TRUE(first.out.connect(second.in));

  class Shell final : public rtm::Component {
   public:
    Shell() : Component("servo0", "servo") {}
    void on_cycle(const rtm::CycleContext&) override {}
  };
  rtm::ComponentServant shell(std::make_unique<Shell>(), rtm::ExternalTick{});
  RTM::RtComponentEx_var shell_ref = shell.activate(orb());
  RTM::InPortEx_var first_in = first.in.reference();
  shell.expose_in_port(0, first_in.in());
  EXPECT_THROW(shell.expose_in_port(5, first_in.in()), std::out_of_range);

  rtm::SharedTick tick(fast());
  tick.add(first_servant.cycle_function());
  tick.add(second_servant.cycle_function());
  first_servant.set_timing_source(&tick);
  first_ref->on();
  second_ref->on();
  tick.start();

  RTM::InPortList_var shell_ins = shell_ref->in_ports();
  ASSERT_EQ(shell_ins->length(), 1u);
  EXPECT_TRUE(shell_ins[0]->_is_equivalent(first_in.in()));
  CORBA::Any a;
  a <<= float6(1.0f);
  shell_ins[0]->put(a);
  RTM::TimedFloat6 out{};
  ASSERT_TRUE(eventually([&] { return second.out.latest(out); }));
  EXPECT_FLOAT_EQ(out.val[0], 4.0f);  // doubled twice
  tick.stop();
  EXPECT_GT(first_ref->timing().cycles, 0u);
  first_ref->off();
  second_ref->off();
}

}  // namespace
