// SPDX-License-Identifier: Apache-2.0
// Ports between real processes: push once and repeated, get, type checks on subscribe and
// put, a subscriber that dies mid-stream, and in-process detection across processes.
#include "integration_fixture.h"

#include "rtm/data.h"
#include "rtm/inport.h"
#include "rtm/outport.h"
#include "rtm_test/raw_giop.h"

#include <signal.h>

#include <unistd.h>

#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>

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

// val[0] of the latest datum `out` holds: on rtm-test-component's out0, the cycle that wrote it.
float latest_ramp(RTM::OutPort_ptr out) {
  CORBA::Any_var value = out->get();
  return from_any(value.in()).val[0];
}

TEST_F(IntegrationTest, OnceSubscriptionDeliversExactlyOneDatumThenEnds) {
  start_component("pub0", {"--on"});
  auto out = out_port("pub0", "out0");
  Probe probe;
  ASSERT_TRUE(out->subscribe(RTM::once, probe.ref));
  ASSERT_TRUE(eventually([&] { return probe.accepted() >= 1; }));
  // 100 periods later (the ramp moved on by 100): still one, and the subscription is gone.
  const float then = latest_ramp(out);
  ASSERT_TRUE(eventually([&] { return latest_ramp(out) >= then + 100.0f; })) << "the component kept running";
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
  // 100 periods later (the ramp moved on by 100) nothing more came.
  const float then = latest_ramp(out);
  ASSERT_TRUE(eventually([&] { return latest_ramp(out) >= then + 100.0f; })) << "the component kept running";
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
  // 50 periods later (the ramp moved on by 50) nothing came.
  const float then = latest_ramp(out);
  ASSERT_TRUE(eventually([&] { return latest_ramp(out) >= then + 50.0f; })) << "the component kept running";
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
  const auto sub = component("sub0");
  const auto cycles = sub->timing().cycles;
  ASSERT_TRUE(eventually([&] { return sub->timing().cycles >= cycles + 50; })) << "the component kept running";
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

  // A write that waited on the dead peer would have held one cycle for the 1 s call timeout;
  // the overrun count is left alone: on these hosts stalls of a few ms come every 100 ms or so.
  EXPECT_LT(after.lateness_max_ns, 500'000'000u)
      << "a cycle " << after.lateness_max_ns / 1'000'000 << " ms late; overruns " << before.overruns << " -> "
      << after.overruns;
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
  // Who makes CORBA calls: the probe, an InPort of another process on this host, would
  // otherwise read the components' rings and no call would be made.
  start_component("writer0", {"--on", "--shared-memory", "off"});
  start_component("thread0", {"--on", "--delivery", "thread", "--shared-memory", "off"});
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

// omniORB 4.2 unmarshals an any holding an any in time that doubles per level: 40 levels in a
// 232-byte request once kept a component's ORB thread busy for hours. Such a request (built
// byte by byte: omniORB's own marshalling of it takes as long) is refused from its first
// TypeCode, before its argument is read; the component answers and stops as usual.
// CPU time (user + system) the process has used, from /proc.
std::int64_t cpu_us(pid_t pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string text((std::istreambuf_iterator<char>(stat)), std::istreambuf_iterator<char>());
  std::istringstream fields(text.substr(text.rfind(')') + 2));
  std::string skip;
  for (int i = 0; i < 11; ++i) fields >> skip;  // state .. cmajflt
  long long utime = 0, stime = 0;
  fields >> utime >> stime;
  return (utime + stime) * 1'000'000 / ::sysconf(_SC_CLK_TCK);
}

TEST_F(IntegrationTest, APutOfAnAnyNestedFortyDeepIsRefusedBeforeItIsReadAndTheComponentStillStops) {
  // Open to anyone: the screen does not depend on the access key.
  auto& process = start_component("nest0", {"--access", "open"});
  auto c = component("nest0");
  RTM::InPortList_var ins = c->in_ports();
  ASSERT_GT(ins->length(), 0u);
  const rtm_test::IiopProfile target = rtm_test::iiop_profile(test_orb().to_string(ins[0]));
  rtm_test::CdrWriter nested;  // put(any): an any holding an any ... 40 deep, then a null
  for (int level = 0; level < 40; ++level) nested.ulong(static_cast<std::uint32_t>(CORBA::tk_any));
  nested.ulong(static_cast<std::uint32_t>(CORBA::tk_null));
  for (const char* operation : {"put", "put_in_order"}) {
    const auto reply = rtm_test::giop_request(target, operation, nested.bytes(), 10'000);
    ASSERT_TRUE(reply.has_value()) << operation << ": no reply within 10 s";
    EXPECT_EQ(reply->status, 2u) << operation << ": a system exception";
    EXPECT_EQ(reply->exception, "IDL:omg.org/CORBA/BAD_PARAM:1.0") << operation;
    EXPECT_EQ(reply->minor, rtm::kNotPlainDataMinor) << operation;
    EXPECT_EQ(reply->completed, 1u) << operation << ": COMPLETED_NO";
  }
  // The figure (docs/safety.md): the component's CPU time per refused request, over 200.
  const std::int64_t cpu_before = cpu_us(process.pid());
  for (int i = 0; i < 200; ++i) ASSERT_TRUE(rtm_test::giop_request(target, "put", nested.bytes(), 10'000));
  RecordProperty("component_cpu_us_per_refusal", static_cast<int>((cpu_us(process.pid()) - cpu_before) / 200));
  EXPECT_EQ(c->state(), RTM::COMPONENT_OFF) << "it still answers";
  CORBA::Any good;
  good <<= RTM::TimedFloat6{};
  EXPECT_NO_THROW(ins[0]->put(good)) << "a plain datum still goes in";
  EXPECT_TRUE(process.stop().clean()) << "stops on SIGTERM";
}

}  // namespace
}  // namespace rtm_it
