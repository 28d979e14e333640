// SPDX-License-Identifier: Apache-2.0
#include "core_test_support.h"

#include "rtm/inport.h"

#include <gtest/gtest.h>

#include <array>
#include <span>
#include <thread>

namespace {

using rtm::ReadResult;
using rtm::test::float3;
using rtm::test::float6;

class InPortTest : public rtm::test::OrbTest {};

using Port6 = rtm::InPort<RTM::TimedFloat6>;

PortableServer::Servant_var<Port6> make_port(rtm::InPortPolicy policy = rtm::InPortPolicy::latest()) {
  return new Port6("in1", "controller0", std::move(policy));
}

CORBA::Any any_of(const RTM::TimedFloat6& d) {
  CORBA::Any a;
  a <<= d;
  return a;
}

TEST_F(InPortTest, PutOfTheRightTypeThroughTheOrbIsStored) {
  auto port = make_port();
  RTM::InPortEx_var ref = port->activate(orb());
  ref->put(any_of(float6(1.0f)));
  RTM::TimedFloat6 got{};
  ASSERT_EQ(port->read(got), ReadResult::NewData);
  EXPECT_FLOAT_EQ(got.val[0], 1.0f);
  EXPECT_FLOAT_EQ(got.val[5], 6.0f);
  EXPECT_EQ(ref->counters().accepted, 1u);
  port->deactivate();
}

TEST_F(InPortTest, PutOfAWrongTypeRaisesBadParamStoresNothingAndIsCounted) {
  auto port = make_port();
  RTM::InPortEx_var ref = port->activate(orb());
  ref->put(any_of(float6(1.0f)));
  CORBA::Any wrong;
  wrong <<= float3(9.0f);
  try {
    ref->put(wrong);
    FAIL() << "put of a TimedFloat3 into a TimedFloat6 port did not raise";
  } catch (const CORBA::BAD_PARAM& e) {
    EXPECT_EQ(e.minor(), rtm::kMinorWrongDataType);
    EXPECT_EQ(e.completed(), CORBA::COMPLETED_NO);
  }
  CORBA::Any a_long;
  a_long <<= static_cast<CORBA::Long>(7);
  EXPECT_THROW(ref->put(a_long), CORBA::BAD_PARAM);

  RTM::TimedFloat6 got{};
  ASSERT_EQ(port->read(got), ReadResult::NewData);
  EXPECT_FLOAT_EQ(got.val[0], 1.0f);  // the earlier datum, untouched
  const RTM::PortCounters c = ref->counters();
  EXPECT_EQ(c.accepted, 1u);
  EXPECT_EQ(c.rejected, 2u);
  CORBA::String_var why = ref->last_error();
  EXPECT_STREQ(why.in(), "put on controller0.in1: expected RTM::TimedFloat6, got long");
  port->deactivate();
}

TEST_F(InPortTest, LastErrorNamesPortAndBothTimedTypes) {
  auto port = make_port();
  CORBA::Any wrong;
  wrong <<= float3(9.0f);
  EXPECT_THROW(port->put(wrong), CORBA::BAD_PARAM);
  EXPECT_EQ(port->last_error_text(), "put on controller0.in1: expected RTM::TimedFloat6, got RTM::TimedFloat3");
  EXPECT_EQ(port->queued(), 0u);
}

TEST_F(InPortTest, OnewayPushStoresOrCountsWithoutRaising) {
  auto port = make_port();
  RTM::InPortEx_var ref = port->activate(orb());
  CORBA::Any wrong;
  wrong <<= float3(9.0f);
  ref->push(wrong);
  ref->push(any_of(float6(4.0f)));
  ASSERT_TRUE(rtm::test::eventually([&] { return port->counters_snapshot().accepted == 1; }));
  EXPECT_EQ(port->counters_snapshot().rejected, 1u);
  port->deactivate();
}

// put_in_order keeps each sender's order: a datum that arrives after a later one of its
// sender (behind a call that timed out) is dropped and counted, and cannot replace it.
TEST_F(InPortTest, AnOrderedPutOlderThanOneAlreadyTakenFromItsSenderIsDroppedAsLate) {
  auto port = make_port();
  RTM::InPortEx_var ex = port->activate(orb());
  RTM::InPortOrdered_var ref = RTM::InPortOrdered::_narrow(ex);
  ASSERT_FALSE(CORBA::is_nil(ref)) << "every RTM InPort keeps senders' order";
  ref->put_in_order(any_of(float6(1.0f)), 42, 1);
  ref->put_in_order(any_of(float6(3.0f)), 42, 3);
  ref->put_in_order(any_of(float6(2.0f)), 42, 2);  // late
  ref->put_in_order(any_of(float6(9.0f)), 43, 1);  // another sender
  RTM::TimedFloat6 got{};
  ASSERT_EQ(port->read(got), ReadResult::NewData);
  EXPECT_FLOAT_EQ(got.val[0], 9.0f);
  const rtm::InPortCounters c = port->counters_snapshot();
  EXPECT_EQ(c.accepted, 3u);
  EXPECT_EQ(c.late, 1u);
  EXPECT_EQ(c.dropped, 3u) << "1 and 3 overwritten unread, 2 late";
  EXPECT_EQ(ref->counters().dropped, c.dropped);

  // A wrong type is refused as by put(), also oneway.
  CORBA::Any wrong;
  wrong <<= float3(1.0f);
  EXPECT_THROW(ref->put_in_order(wrong, 42, 10), CORBA::BAD_PARAM);
  ref->push_in_order(wrong, 42, 11);
  ref->push_in_order(any_of(float6(5.0f)), 42, 12);
  ASSERT_TRUE(rtm::test::eventually([&] { return port->counters_snapshot().accepted == 4; }));
  EXPECT_EQ(port->counters_snapshot().rejected, 2u);
  port->deactivate();
}

TEST_F(InPortTest, AttributesNameTypeAndOwner) {
  auto port = make_port();
  RTM::InPortEx_var ref = port->activate(orb());
  CORBA::String_var name = ref->name();
  CORBA::String_var owner = ref->owner();
  CORBA::TypeCode_var type = ref->port_type();
  EXPECT_STREQ(name.in(), "in1");
  EXPECT_STREQ(owner.in(), "controller0");
  EXPECT_TRUE(type->equivalent(RTM::_tc_TimedFloat6));
  EXPECT_EQ(port->full_name(), "controller0.in1");
  // A seed client sees a plain RTM::InPort.
  RTM::InPort_var seed = RTM::InPort::_narrow(ref.in());
  ASSERT_FALSE(CORBA::is_nil(seed));
  seed->put(any_of(float6(2.0f)));
  EXPECT_EQ(port->counters_snapshot().accepted, 1u);
  port->deactivate();
}

TEST_F(InPortTest, LatestReportsNoDataThenNewDataThenOldData) {
  auto port = make_port();
  RTM::TimedFloat6 got = float6(-1.0f);
  EXPECT_EQ(port->read(got), ReadResult::NoData);
  EXPECT_FLOAT_EQ(got.val[0], -1.0f);  // untouched
  port->deliver(float6(1.0f));
  port->deliver(float6(2.0f));  // overwrites the unread 1.0: dropped
  EXPECT_EQ(port->read(got), ReadResult::NewData);
  EXPECT_FLOAT_EQ(got.val[0], 2.0f);
  EXPECT_EQ(port->read(got), ReadResult::OldData);
  EXPECT_FLOAT_EQ(got.val[0], 2.0f);
  const auto c = port->counters_snapshot();
  EXPECT_EQ(c.accepted, 2u);
  EXPECT_EQ(c.dropped, 1u);
  EXPECT_EQ(c.in_process, 2u);
}

TEST_F(InPortTest, FifoDropOldestKeepsTheNewest) {
  auto port = make_port(rtm::InPortPolicy::fifo(3, rtm::FullPolicy::DropOldest));
  for (int i = 1; i <= 5; ++i) port->deliver(float6(static_cast<float>(i)));
  EXPECT_EQ(port->queued(), 3u);
  RTM::TimedFloat6 got{};
  for (float expected : {3.0f, 4.0f, 5.0f}) {
    ASSERT_EQ(port->read(got), ReadResult::NewData);
    EXPECT_FLOAT_EQ(got.val[0], expected);
  }
  EXPECT_EQ(port->read(got), ReadResult::OldData);
  EXPECT_FLOAT_EQ(got.val[0], 5.0f);
  EXPECT_EQ(port->counters_snapshot().dropped, 2u);
  EXPECT_EQ(port->counters_snapshot().accepted, 5u);
}

TEST_F(InPortTest, ReadManyTakesTheNewDataOldestFirstAsManyAsFitThenTheRest) {
  auto fifo = make_port(rtm::InPortPolicy::fifo(8));
  for (int i = 1; i <= 5; ++i) fifo->deliver(float6(static_cast<float>(i)));
  std::array<RTM::TimedFloat6, 3> three{};
  ASSERT_EQ(fifo->read_many(three), 3u);
  EXPECT_FLOAT_EQ(three[0].val[0], 1.0f);
  EXPECT_FLOAT_EQ(three[2].val[0], 3.0f);
  std::array<RTM::TimedFloat6, 8> rest{};
  ASSERT_EQ(fifo->read_many(rest), 2u);
  EXPECT_FLOAT_EQ(rest[0].val[0], 4.0f);
  EXPECT_FLOAT_EQ(rest[1].val[0], 5.0f);
  EXPECT_EQ(fifo->read_many(rest), 0u);
  RTM::TimedFloat6 last{};
  EXPECT_EQ(fifo->read(last), ReadResult::OldData) << "read() after read_many() knows what was read last";
  EXPECT_FLOAT_EQ(last.val[0], 5.0f);

  auto latest = make_port();
  EXPECT_EQ(latest->read_many(rest), 0u);
  latest->deliver(float6(7.0f));
  latest->deliver(float6(8.0f));
  ASSERT_EQ(latest->read_many(rest), 1u) << "a latest port gives its newest datum once";
  EXPECT_FLOAT_EQ(rest[0].val[0], 8.0f);
  EXPECT_EQ(latest->read_many(rest), 0u);
  EXPECT_EQ(latest->read_many(std::span<RTM::TimedFloat6>{}), 0u);
}

TEST_F(InPortTest, FifoDropNewestKeepsTheOldest) {
  auto port = make_port(rtm::InPortPolicy::fifo(2, rtm::FullPolicy::DropNewest));
  RTM::TimedFloat6 got{};
  EXPECT_EQ(port->read(got), ReadResult::NoData);
  for (int i = 1; i <= 4; ++i) port->deliver(float6(static_cast<float>(i)));
  for (float expected : {1.0f, 2.0f}) {
    ASSERT_EQ(port->read(got), ReadResult::NewData);
    EXPECT_FLOAT_EQ(got.val[0], expected);
  }
  EXPECT_EQ(port->counters_snapshot().dropped, 2u);
  EXPECT_EQ(port->counters_snapshot().accepted, 2u);
}

TEST_F(InPortTest, FifoBlockDropsTheNewDatumAfterTheTimeout) {
  auto port = make_port(rtm::InPortPolicy::fifo(1, rtm::FullPolicy::Block, 1'000'000));
  port->deliver(float6(1.0f));
  port->deliver(float6(2.0f));  // waits 1 ms for room, none comes
  RTM::TimedFloat6 got{};
  ASSERT_EQ(port->read(got), ReadResult::NewData);
  EXPECT_FLOAT_EQ(got.val[0], 1.0f);
  EXPECT_EQ(port->read(got), ReadResult::OldData);
  EXPECT_EQ(port->counters_snapshot().dropped, 1u);
}

TEST_F(InPortTest, FifoBlockPutterProceedsWhenAReaderMakesRoom) {
  // 20 s timeout: the putter must be released by the read, not by the timeout.
  auto port = make_port(rtm::InPortPolicy::fifo(1, rtm::FullPolicy::Block, 20'000'000'000));
  port->deliver(float6(1.0f));
  std::atomic<bool> second_stored{false};
  std::thread putter([&] {
    port->deliver(float6(2.0f));
    second_stored = true;
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(5));
  EXPECT_FALSE(second_stored.load());
  RTM::TimedFloat6 got{};
  ASSERT_EQ(port->read(got), ReadResult::NewData);
  putter.join();
  EXPECT_TRUE(second_stored.load());
  ASSERT_EQ(port->read(got), ReadResult::NewData);
  EXPECT_FLOAT_EQ(got.val[0], 2.0f);
  EXPECT_EQ(port->counters_snapshot().dropped, 0u);
}

TEST_F(InPortTest, CallbackPolicyCallsTheFunctionWithEachDatumAndKeepsTheLatest) {
  std::vector<float> seen;
  auto port = make_port(rtm::InPortPolicy::callback<RTM::TimedFloat6>(
      [&](const RTM::TimedFloat6& d) { seen.push_back(d.val[0]); }));
  RTM::InPortEx_var ref = port->activate(orb());
  ref->put(any_of(float6(1.0f)));
  port->deliver(float6(2.0f));
  ASSERT_EQ(seen.size(), 2u);
  EXPECT_FLOAT_EQ(seen[0], 1.0f);
  EXPECT_FLOAT_EQ(seen[1], 2.0f);
  RTM::TimedFloat6 got{};
  EXPECT_EQ(port->read(got), ReadResult::NewData);
  EXPECT_FLOAT_EQ(got.val[0], 2.0f);
  port->deactivate();
}

TEST_F(InPortTest, ThrowingCallbackIsCountedNotPropagated) {
  auto port = make_port(rtm::InPortPolicy::callback<RTM::TimedFloat6>(
      [](const RTM::TimedFloat6&) { throw std::runtime_error("listener broke"); }));
  EXPECT_NO_THROW(port->deliver(float6(1.0f)));
  EXPECT_NO_THROW(port->deliver(float6(2.0f)));
  EXPECT_EQ(port->counters_snapshot().callback_failures, 2u);
  EXPECT_EQ(port->counters_snapshot().accepted, 2u);
}

TEST_F(InPortTest, CallbackForAnotherTypeIsRefusedAtConstruction) {
  auto policy = rtm::InPortPolicy::callback<RTM::TimedFloat3>([](const RTM::TimedFloat3&) {});
  EXPECT_THROW(Port6("in0", "x", policy), std::invalid_argument);
}

TEST_F(InPortTest, BadPolicyArgumentsAreRefused) {
  EXPECT_THROW(rtm::InPortPolicy::fifo(0), std::invalid_argument);
  EXPECT_THROW(rtm::InPortPolicy::fifo(2, rtm::FullPolicy::Block, 0), std::invalid_argument);
  EXPECT_THROW(Port6("", "x"), std::invalid_argument);
}

TEST_F(InPortTest, ArrivalSignalIsBumpedPerStoredDatum) {
  auto port = make_port(rtm::InPortPolicy::fifo(1, rtm::FullPolicy::DropNewest));
  auto signal = std::make_shared<rtm::ArrivalSignal>();
  port->set_arrival_signal(signal);
  port->deliver(float6(1.0f));
  port->deliver(float6(2.0f));  // dropped: no arrival
  EXPECT_EQ(signal->count(), 1u);
  port->set_arrival_signal(nullptr);
}

TEST_F(InPortTest, FindLocalKnowsActivatedPortsOnly) {
  auto port = make_port();
  EXPECT_EQ(rtm::InPortBase::find_local(CORBA::Object::_nil()).in(), nullptr);
  RTM::InPortEx_var ref = port->activate(orb());
  EXPECT_EQ(rtm::InPortBase::find_local(ref.in()).in(), port.in());
  port->deactivate();
  EXPECT_EQ(rtm::InPortBase::find_local(ref.in()).in(), nullptr);
}

}  // namespace
