// Ports between real processes: push once and repeated, get, type checks on subscribe and
// put, a subscriber that dies mid-stream, and in-process detection across processes.
#include "integration_fixture.h"

#include "rtm/data.h"
#include "rtm/inport.h"
#include "rtm/outport.h"

#include <signal.h>

#include <limits>

namespace rtm_it {
namespace {

using Float6In = rtm::InPort<RTM::TimedFloat6>;
using Float6Out = rtm::OutPort<RTM::TimedFloat6>;

// An InPort of the test process that queues everything it receives.
struct Probe {
  PortableServer::Servant_var<Float6In> port{new Float6In("probe", "itest", rtm::InPortPolicy::fifo(4096))};
  RTM::InPortEx_var ref = port->activate(test_orb());
  ~Probe() { port->deactivate(); }
  std::uint64_t accepted() const { return port->counters_snapshot().accepted; }
};

RTM::TimedFloat6 datum(float first) {
  RTM::TimedFloat6 d{};
  d.tm = rtm::now();
  for (CORBA::ULong i = 0; i < 6; ++i) d.val[i] = first + static_cast<float>(i);
  return d;
}

CORBA::Any to_any(const RTM::TimedFloat6& d) {
  CORBA::Any any;
  any <<= d;
  return any;
}

RTM::TimedFloat6 from_any(const CORBA::Any& any) {
  const RTM::TimedFloat6* d = nullptr;
  if (!(any >>= d)) throw std::runtime_error("any does not hold a TimedFloat6");
  return *d;
}

TEST_F(IntegrationTest, OnceSubscriptionDeliversExactlyOneDatumThenEnds) {
  start_component("pub0", {"--on"});
  auto out = out_port("pub0", "out0");
  Probe probe;
  ASSERT_TRUE(out->subscribe(RTM::once, probe.ref));
  ASSERT_TRUE(eventually([&] { return probe.accepted() >= 1; }));
  // 100 periods later: still one, and the subscription is gone.
  std::this_thread::sleep_for(200ms);
  EXPECT_EQ(probe.accepted(), 1u);
  RTM::SubscriptionInfoList_var subs = out->subscriptions();
  EXPECT_EQ(subs->length(), 0u);
}

TEST_F(IntegrationTest, RepeatedSubscriptionDeliversTheRampInOrderUntilUnsubscribed) {
  start_component("pub0", {"--on"});
  auto out = out_port("pub0", "out0");
  Probe probe;
  ASSERT_TRUE(out->subscribe(RTM::repeated, probe.ref));
  ASSERT_TRUE(eventually([&] { return probe.accepted() >= 50; }));
  ASSERT_TRUE(out->unsubscribe(RTM::repeated, probe.ref));
  const auto after_unsubscribe = probe.accepted();
  std::this_thread::sleep_for(200ms);
  EXPECT_EQ(probe.accepted(), after_unsubscribe);
  EXPECT_FALSE(out->unsubscribe(RTM::repeated, probe.ref)) << "a second unsubscribe found something";

  RTM::TimedFloat6 previous{}, current{};
  ASSERT_EQ(probe.port->read(previous), rtm::ReadResult::NewData);
  std::size_t read = 1;
  while (probe.port->read(current) == rtm::ReadResult::NewData) {
    EXPECT_GT(current.val[0], previous.val[0]) << "datum " << read;
    EXPECT_EQ(current.val[5], current.val[0] + 5.0f);
    previous = current;
    ++read;
  }
  EXPECT_EQ(read, after_unsubscribe);
}

TEST_F(IntegrationTest, GetBeforeTheFirstDatumRaisesNoDataYetAndAfterReturnsTheLatest) {
  start_component("pub0");
  auto out = out_port("pub0", "out0");
  try {
    CORBA::Any_var nothing = out->get();
    FAIL() << "get before any write returned a value";
  } catch (const CORBA::BAD_INV_ORDER& e) {
    EXPECT_EQ(e.minor(), rtm::kMinorNoDataYet);
  }
  component("pub0")->on();
  RTM::TimedFloat6 first{};
  ASSERT_TRUE(eventually([&] {
    try {
      CORBA::Any_var value = out->get();
      first = from_any(value.in());
      return true;
    } catch (const CORBA::BAD_INV_ORDER&) {
      return false;
    }
  }));
  EXPECT_EQ(first.val[1], first.val[0] + 1.0f);
  // The value moves on with the ramp.
  ASSERT_TRUE(eventually([&] {
    CORBA::Any_var value = out->get();
    return from_any(value.in()).val[0] > first.val[0];
  }));
}

TEST_F(IntegrationTest, SubscribeOfAnInPortOfAnotherTypeIsRefusedNamingBothTypes) {
  start_component("pub0", {"--on"});
  start_component("sub0");
  auto out = out_port("pub0", "out0");
  auto float3_in = in_port("sub0", "in3");
  EXPECT_FALSE(out->subscribe(RTM::repeated, float3_in));
  CORBA::String_var why = out->last_error();
  EXPECT_NE(std::string(why.in()).find("RTM::TimedFloat6"), std::string::npos) << why.in();
  EXPECT_NE(std::string(why.in()).find("RTM::TimedFloat3"), std::string::npos) << why.in();
  RTM::SubscriptionInfoList_var subs = out->subscriptions();
  EXPECT_EQ(subs->length(), 0u);
  EXPECT_EQ(out->counters().rejected, 1u);
  std::this_thread::sleep_for(100ms);
  EXPECT_EQ(float3_in->counters().accepted, 0u);
}

TEST_F(IntegrationTest, PutOfTheWrongTypeIsRejectedAndTheInPortKeepsItsDatum) {
  start_component("sub0", {"--on"});
  auto in = in_port("sub0", "in0");
  auto echo = out_port("sub0", "echo");
  const auto good = datum(42.0f);
  in->put(to_any(good));
  ASSERT_TRUE(eventually([&] { return echo->counters().accepted == 1; }));

  RTM::TimedFloat3 wrong{};
  wrong.val[0] = -1.0f;
  CORBA::Any wrong_any;
  wrong_any <<= wrong;
  try {
    in->put(wrong_any);
    FAIL() << "put of a TimedFloat3 into a TimedFloat6 port was accepted";
  } catch (const CORBA::BAD_PARAM& e) {
    EXPECT_EQ(e.minor(), rtm::kMinorWrongDataType);
  }
  const auto counters = in->counters();
  EXPECT_EQ(counters.accepted, 1u);
  EXPECT_EQ(counters.rejected, 1u);
  CORBA::String_var why = in->last_error();
  EXPECT_NE(std::string(why.in()).find("TimedFloat3"), std::string::npos) << why.in();

  // Many cycles later the component has seen nothing new: the echo is still the good datum.
  std::this_thread::sleep_for(100ms);
  EXPECT_EQ(echo->counters().accepted, 1u);
  CORBA::Any_var echoed = echo->get();
  EXPECT_EQ(from_any(echoed.in()).val[0], 42.0f);
}

TEST_F(IntegrationTest, PublisherKeepsItsPeriodAndDropsASubscriberKilledMidStream) {
  start_component("pub0");
  auto& subscriber = start_component("sub0");
  auto out = out_port("pub0", "out0");
  auto in = in_port("sub0", "in0");
  ASSERT_TRUE(out->subscribe(RTM::repeated, in));
  auto pub = component("pub0");
  pub->on();
  ASSERT_TRUE(eventually([&] { return in->counters().accepted >= 100; }));

  const RTM::TimingStats before = pub->timing();
  subscriber.kill_now();
  ASSERT_TRUE(eventually([&] {
    RTM::SubscriptionInfoList_var subs = out->subscriptions();
    return subs->length() == 0;
  })) << "the dead subscriber was never dropped";
  EXPECT_GE(out->counters().failed, 1u);
  // Let the publisher run on without it for a while.
  const auto cycles_when_dropped = pub->timing().cycles;
  ASSERT_TRUE(eventually([&] { return pub->timing().cycles >= cycles_when_dropped + 250; }));
  const RTM::TimingStats after = pub->timing();

  // A write that waited on the dead peer (1 s call timeout) would cost hundreds of overruns;
  // the odd host stall costs a few.
  EXPECT_LT(after.overruns - before.overruns, 20u) << "overruns " << before.overruns << " -> " << after.overruns;
  EXPECT_EQ(pub->state(), RTM::COMPONENT_ON);
}

TEST_F(IntegrationTest, AReferenceFromAnotherProcessIsNotTakenForAnInProcessOne) {
  start_component("pub0", {"--on"});
  start_component("sub0");
  auto out = out_port("pub0", "out0");
  Probe probe;
  ASSERT_TRUE(out->subscribe(RTM::repeated, in_port("sub0", "in0")));
  ASSERT_TRUE(out->subscribe(RTM::repeated, probe.ref));
  ASSERT_TRUE(eventually([&] { return probe.accepted() >= 10; }));
  RTM::SubscriptionInfoList_var subs = out->subscriptions();
  ASSERT_EQ(subs->length(), 2u);
  for (CORBA::ULong i = 0; i < subs->length(); ++i) EXPECT_FALSE(subs[i].in_process) << subs[i].peer.in();
  EXPECT_EQ(probe.port->counters_snapshot().in_process, 0u);

  // Positive control in this process: an OutPort here does take our own probe as local, and
  // still not the other process's InPort.
  PortableServer::Servant_var<Float6Out> local_out(new Float6Out("local", "itest"));
  RTM::OutPortEx_var local_ref = local_out->activate(orb());
  ASSERT_TRUE(local_ref->subscribe(RTM::repeated, probe.ref));
  ASSERT_TRUE(local_ref->subscribe(RTM::repeated, in_port("sub0", "in0")));
  RTM::SubscriptionInfoList_var local_subs = local_ref->subscriptions();
  ASSERT_EQ(local_subs->length(), 2u);
  EXPECT_TRUE(local_subs[0].in_process);
  EXPECT_FALSE(local_subs[1].in_process);
  local_out->close();
  local_out->deactivate();
}

// The component's statistics, by name (a missing one: NaN, so that comparisons fail).
double statistic(RTM::RtComponentEx_ptr component, const std::string& name) {
  RTM::StatisticList_var stats = component->statistics();
  for (CORBA::ULong i = 0; i < stats->length(); ++i) {
    if (name == stats[i].name.in()) return stats[i].value;
  }
  return std::numeric_limits<double>::quiet_NaN();
}

// --delivery reaches every OutPort of a component process, and each port's statistics say
// who made its calls: by default write() itself, with --delivery thread never.
TEST_F(IntegrationTest, DeliveryOptionChoosesWhoCallsAndThePortsStatisticsSayWho) {
  start_component("writer0", {"--on"});
  start_component("thread0", {"--on", "--delivery", "thread"});
  Probe from_writer, from_thread;
  ASSERT_TRUE(out_port("writer0", "out0")->subscribe(RTM::repeated, from_writer.ref));
  ASSERT_TRUE(out_port("thread0", "out0")->subscribe(RTM::repeated, from_thread.ref));
  ASSERT_TRUE(eventually([&] { return from_writer.accepted() >= 50 && from_thread.accepted() >= 50; }));

  auto writer = component("writer0");
  auto thread = component("thread0");
  EXPECT_GT(statistic(writer, "out0.by_writer"), 0.0) << "an idle subscription is called by write() itself";
  EXPECT_EQ(statistic(thread, "out0.by_writer"), 0.0) << "--delivery thread: write() never calls";
  for (auto* c : {writer.in(), thread.in()}) {
    EXPECT_GT(statistic(c, "out0.write_max"), 0.0) << "write()'s cost is measured";
    EXPECT_LE(statistic(c, "out0.write_p50"), statistic(c, "out0.write_p99"));
    EXPECT_LE(statistic(c, "out0.write_p99"), statistic(c, "out0.write_max"));
    EXPECT_EQ(statistic(c, "echo.timed_out"), 0.0) << "every OutPort reports, not only the first";
  }
}

}  // namespace
}  // namespace rtm_it
