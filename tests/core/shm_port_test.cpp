// SPDX-License-Identifier: Apache-2.0
// Ports on the same-host path: an OutPort offers its shared-memory ring at subscribe and an
// InPort that can read it takes data from it when its component reads, with no call per datum.
// Here the InPort is in the test's own process, reached through the ORB with the in-process
// path off, as one of another process is (outport_test.cpp runs one in another process).
#include "core_test_support.h"

#include "rt/clock.h"
#include "rtm/outport.h"

#include <gtest/gtest.h>

#include <array>
#include <atomic>

#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace {

using rtm::ReadResult;
using namespace rtm::test;  // eventually, float6, In6, Out6, OrbTest

class ShmPortTest : public rtm::test::OrbTest {
 protected:
  static rtm::OutPortOptions through_ring() {
    rtm::OutPortOptions o;
    o.in_process = false;  // as if the InPort were in another process of this host
    return o;
  }
  PortableServer::Servant_var<Out6> make_out() { return new Out6("out0", "sensor0", through_ring()); }
  PortableServer::Servant_var<In6> make_in(rtm::InPortPolicy policy = rtm::InPortPolicy::latest()) {
    return new In6("in0", "controller0", std::move(policy));
  }
  // An OutPort through a ring and an InPort of policy, activated and subscribed.
  struct Wired {
    PortableServer::Servant_var<Out6> out;
    PortableServer::Servant_var<In6> in;
    RTM::InPortEx_var ref;
  };
  Wired wired(rtm::InPortPolicy policy = rtm::InPortPolicy::latest()) {
    Wired w{make_out(), make_in(std::move(policy)), {}};
    w.ref = w.in->activate(orb());
    if (!w.out->subscribe(RTM::repeated, w.ref.in())) ADD_FAILURE() << "the subscription was refused";
    return w;
  }
  static std::string path_of(Out6& out) {
    RTM::SubscriptionInfoList_var subs = out.subscriptions();
    if (subs->length() != 1) return "not one subscription";
    return subs[0].path.in();
  }
};

TEST_F(ShmPortTest, AFifoSubscriberTakesEveryDatumInOrderWhenItReadsAndNoCallIsMade) {
  auto out = make_out();
  auto in = make_in(rtm::InPortPolicy::fifo(8));
  RTM::InPortEx_var ref = in->activate(orb());
  out->write(float6(0.0f));  // before the subscription: not for it
  ASSERT_TRUE(out->subscribe(RTM::repeated, ref.in()));
  EXPECT_EQ(path_of(*out), "shared memory");
  EXPECT_EQ(in->attached_rings(), 1u);
  for (int i = 1; i <= 5; ++i) out->write(float6(static_cast<float>(i)));
  RTM::TimedFloat6 got{};
  for (float want : {1.0f, 2.0f, 3.0f, 4.0f, 5.0f}) {
    ASSERT_EQ(in->read(got), ReadResult::NewData);
    EXPECT_FLOAT_EQ(got.val[0], want);
  }
  EXPECT_EQ(in->read(got), ReadResult::OldData);
  const rtm::OutPortCounters oc = out->counters_snapshot();
  EXPECT_EQ(oc.by_writer, 0u) << "write() made no call";
  EXPECT_EQ(oc.failed, 0u);
  EXPECT_EQ(oc.pushed, 5u);
  const rtm::InPortCounters ic = in->counters_snapshot();
  EXPECT_EQ(ic.accepted, 5u);
  EXPECT_EQ(ic.shared_memory, 5u);
  EXPECT_EQ(ic.dropped, 0u);
  out->close();
  in->deactivate();
}

TEST_F(ShmPortTest, ALatestSubscriberGetsTheNewestAndCountsWhatItSkippedAsDropped) {
  auto [out, in, ref] = wired();
  RTM::TimedFloat6 got{};
  EXPECT_EQ(in->read(got), ReadResult::NoData);
  for (int i = 1; i <= 10; ++i) out->write(float6(static_cast<float>(i)));
  ASSERT_EQ(in->read(got), ReadResult::NewData);
  EXPECT_FLOAT_EQ(got.val[0], 10.0f);
  EXPECT_EQ(in->read(got), ReadResult::OldData);
  const rtm::InPortCounters c = in->counters_snapshot();
  EXPECT_EQ(c.accepted, 1u);
  EXPECT_EQ(c.dropped, 9u) << "as a put of each would have overwritten the unread one";
  out->close();
  in->deactivate();
}

TEST_F(ShmPortTest, AFifoSubscriberFarBehindCountsTheDataTheRingNoLongerHeldAsDropped) {
  rtm::OutPortOptions options = through_ring();
  options.queue_depth = 8;  // a ring of kMinRingSlots slots
  PortableServer::Servant_var<Out6> out = new Out6("out0", "sensor0", options);
  auto in = make_in(rtm::InPortPolicy::fifo(2 * rtm::kMinRingSlots));  // holds all the ring does
  RTM::InPortEx_var ref = in->activate(orb());
  ASSERT_TRUE(out->subscribe(RTM::repeated, ref.in()));
  const int written = 4 * static_cast<int>(rtm::kMinRingSlots);
  for (int i = 1; i <= written; ++i) out->write(float6(static_cast<float>(i)));
  RTM::TimedFloat6 got{};
  std::vector<float> taken;
  while (in->read(got) == ReadResult::NewData) taken.push_back(got.val[0]);
  ASSERT_FALSE(taken.empty());
  EXPECT_FLOAT_EQ(taken.back(), static_cast<float>(written));
  for (std::size_t k = 1; k < taken.size(); ++k) EXPECT_FLOAT_EQ(taken[k], taken[k - 1] + 1.0f) << "in order";
  const rtm::InPortCounters c = in->counters_snapshot();
  EXPECT_EQ(c.accepted + c.dropped, static_cast<std::uint64_t>(written)) << "every datum either taken or counted as dropped";
  EXPECT_GE(c.dropped, static_cast<std::uint64_t>(written) - rtm::kMinRingSlots) << "the ring held no more than its slots";
  EXPECT_EQ(c.accepted, taken.size());
  out->close();
  in->deactivate();
}

// A FIFO that drops its oldest reads the ring straight (nothing copied into its queue first):
// it still keeps only its capacity's newest, counts the rest as dropped, and a put that
// arrives between ring data is read in its place, after the ring data written before it.
TEST_F(ShmPortTest, AFifoThatDropsItsOldestTakesTheNewestOfItsCapacityAndPutsInArrivalOrder) {
  auto [out, in, ref] = wired(rtm::InPortPolicy::fifo(4));
  for (int i = 1; i <= 10; ++i) out->write(float6(static_cast<float>(i)));
  RTM::TimedFloat6 got{};
  std::vector<float> taken;
  while (in->read(got) == ReadResult::NewData) taken.push_back(got.val[0]);
  EXPECT_EQ(taken, (std::vector<float>{7.0f, 8.0f, 9.0f, 10.0f})) << "the newest 4, as a FIFO of 4 keeps";
  rtm::InPortCounters c = in->counters_snapshot();
  EXPECT_EQ(c.accepted, 4u);
  EXPECT_EQ(c.dropped, 6u);
  EXPECT_EQ(c.shared_memory, 4u);

  out->write(float6(11.0f));
  out->write(float6(12.0f));
  CORBA::Any any;
  any <<= float6(100.0f);
  in->put(any);  // arrives after 11 and 12 were written
  out->write(float6(13.0f));
  std::array<RTM::TimedFloat6, 8> many{};
  const std::size_t n = in->read_many(many);
  std::vector<float> batch;
  for (std::size_t i = 0; i < n; ++i) batch.push_back(many[i].val[0]);
  EXPECT_EQ(batch, (std::vector<float>{11.0f, 12.0f, 100.0f, 13.0f}));
  c = in->counters_snapshot();
  EXPECT_EQ(c.accepted, 8u);
  EXPECT_EQ(c.dropped, 6u);
  out->close();
  in->deactivate();
}

// A write() that only fills the ring costs about a tenth of a microsecond, two clock reads half
// as much again: it times one call in kWriteCostSampling. One that may call is always timed
// (OutPortTest.AnIdleRemoteSubscriptionIsDeliveredByWriteItselfInOrder).
TEST_F(ShmPortTest, WriteTimesOneCallInSixteenWhileItOnlyFillsRings) {
  auto [out, in, ref] = wired(rtm::InPortPolicy::fifo(8));
  for (int i = 1; i <= 160; ++i) out->write(float6(static_cast<float>(i)));
  EXPECT_EQ(out->write_cost().count, 160u / rtm::kWriteCostSampling);
  EXPECT_EQ(out->counters_snapshot().written, 160u);
  out->close();
  in->deactivate();
}

// A periodic reader on a phase after its writer's waits for the datum at the start of its
// cycle, bounded: the ring's next write wakes it (one futex wait), and so does a put.
TEST_F(ShmPortTest, AReaderAwaitingANewDatumIsWokenByTheRingsNextWriteAndByAPut) {
  using Awaited = rtm::InPortBase::Awaited;
  auto [out, in, ref] = wired(rtm::InPortPolicy::fifo(8));
  for (const bool by_put : {false, true}) {
    const std::int64_t deadline = rtm::monotonic_ns() + 60'000'000'000;
    std::atomic<int> found{-1};
    std::atomic<std::int64_t> returned_ns{0};
    std::thread reader([&] {
      found = static_cast<int>(in->wait_new_until(deadline));
      returned_ns = rtm::monotonic_ns();
    });
    ASSERT_TRUE(eventually([&] { return in->awaiting() == 1; }));
    if (by_put) {
      CORBA::Any any;
      any <<= float6(2.0f);
      in->put(any);
    } else {
      out->write(float6(1.0f));
    }
    reader.join();
    EXPECT_EQ(found.load(), static_cast<int>(Awaited::arrived)) << (by_put ? "put" : "ring");
    EXPECT_LT(returned_ns.load(), deadline) << "woken by the datum, not by the deadline";
    RTM::TimedFloat6 got{};
    ASSERT_EQ(in->read(got), ReadResult::NewData);
    EXPECT_FLOAT_EQ(got.val[0], by_put ? 2.0f : 1.0f);
  }
  EXPECT_EQ(in->awaiting(), 0u);
  out->close();
  in->deactivate();
}

TEST_F(ShmPortTest, AnAwaitFindsADatumAlreadyThereAtOnceAndEndsAtItsBoundWhenNoneComes) {
  using Awaited = rtm::InPortBase::Awaited;
  auto [out, in, ref] = wired();
  out->write(float6(1.0f));
  EXPECT_EQ(in->wait_new_until(rtm::monotonic_ns() + 60'000'000'000), Awaited::there);
  RTM::TimedFloat6 got{};
  ASSERT_EQ(in->read(got), ReadResult::NewData);
  const std::int64_t deadline = rtm::monotonic_ns() + 20'000'000;
  EXPECT_EQ(in->wait_new_until(deadline), Awaited::none) << "the datum already read is not new";
  EXPECT_GE(rtm::monotonic_ns(), deadline);
  out->close();
  in->deactivate();
}

TEST_F(ShmPortTest, AfterUnsubscribeNothingMoreArrivesButWhatCameBeforeIsKept) {
  auto [out, in, ref] = wired(rtm::InPortPolicy::fifo(8));
  out->write(float6(1.0f));
  out->write(float6(2.0f));
  ASSERT_TRUE(out->unsubscribe(RTM::repeated, ref.in()));
  EXPECT_EQ(in->attached_rings(), 0u);
  out->write(float6(3.0f));
  RTM::TimedFloat6 got{};
  std::vector<float> taken;
  while (in->read(got) == ReadResult::NewData) taken.push_back(got.val[0]);
  EXPECT_EQ(taken, (std::vector<float>{1.0f, 2.0f}));
  out->close();
  in->deactivate();
}

// A port that acts on each arrival (a callback, a FIFO that blocks, an arrival signal) reads
// the ring too: a thread of its own waits on the ring's futex and stores each datum as a put
// would, in order; read() leaves that ring to it. The thread ends at unsubscribe, keeping what
// came before, and at deactivate.
TEST_F(ShmPortTest, PortsThatActOnArrivalAreWokenByTheRingAndStoreEachDatumInOrder) {
  std::mutex mu;
  std::vector<float> called;
  auto out = make_out();
  auto in = make_in(rtm::InPortPolicy::callback<RTM::TimedFloat6>([&](const RTM::TimedFloat6& d) {
    std::lock_guard lock(mu);
    called.push_back(d.val[0]);
  }));
  RTM::InPortEx_var ref = in->activate(orb());
  ASSERT_TRUE(out->subscribe(RTM::repeated, ref.in()));
  EXPECT_EQ(path_of(*out), "shared memory");
  EXPECT_EQ(in->ring_waiters(), 1u);
  std::vector<float> expected;
  for (int i = 1; i <= 50; ++i) {
    out->write(float6(static_cast<float>(i)));
    expected.push_back(static_cast<float>(i));
  }
  const auto called_count = [&] {
    std::lock_guard lock(mu);
    return called.size();
  };
  ASSERT_TRUE(eventually([&] { return called_count() == 50; })) << "nobody read the port: the thread alone woke";
  {
    std::lock_guard lock(mu);
    EXPECT_EQ(called, expected);
  }
  EXPECT_EQ(in->counters_snapshot().shared_memory, 50u);
  EXPECT_EQ(in->counters_snapshot().accepted, 50u);
  ASSERT_TRUE(out->unsubscribe(RTM::repeated, ref.in()));
  EXPECT_EQ(in->ring_waiters(), 0u);
  out->write(float6(99.0f));
  EXPECT_EQ(called_count(), 50u) << "a datum written after the unsubscribe reached the callback";
  out->close();
  in->deactivate();

  // A FIFO that blocks: every datum, in order, through the ring.
  auto out2 = make_out();
  auto fifo = make_in(rtm::InPortPolicy::fifo(64, rtm::FullPolicy::Block, 1'000'000));
  RTM::InPortEx_var fifo_ref = fifo->activate(orb());
  ASSERT_TRUE(out2->subscribe(RTM::repeated, fifo_ref.in()));
  EXPECT_EQ(path_of(*out2), "shared memory");
  for (int i = 1; i <= 10; ++i) out2->write(float6(static_cast<float>(i)));
  ASSERT_TRUE(eventually([&] { return fifo->queued() == 10; }));
  RTM::TimedFloat6 got{};
  for (int i = 1; i <= 10; ++i) {
    ASSERT_EQ(fifo->read(got), ReadResult::NewData);
    EXPECT_FLOAT_EQ(got.val[0], static_cast<float>(i));
  }
  fifo->deactivate();  // with the ring still attached: its thread ends here
  EXPECT_EQ(fifo->ring_waiters(), 0u);
  out2->close();
}

// An arrival signal set after the ring was attached (a component that makes its activity
// later) is bumped by data from the ring from then on, without a read.
TEST_F(ShmPortTest, AnArrivalSignalSetLaterIsBumpedByTheRing) {
  auto [out, in, ref] = wired(rtm::InPortPolicy::fifo(16));
  EXPECT_EQ(in->ring_waiters(), 0u) << "a FIFO that drops is read in its reader's cycle";
  auto signal = std::make_shared<rtm::ArrivalSignal>();
  in->set_arrival_signal(signal);
  EXPECT_EQ(in->ring_waiters(), 1u);
  out->write(float6(1.0f));
  out->write(float6(2.0f));
  ASSERT_TRUE(eventually([&] { return signal->count() >= 1; }));
  ASSERT_TRUE(eventually([&] { return in->counters_snapshot().shared_memory == 2; }));
  out->close();
  in->deactivate();
}

TEST_F(ShmPortTest, DataThatAreNotPlainMemoryKeepCorba) {
  // A sequence: its datum points elsewhere, a copy of its bytes would carry a pointer.
  using OutSeq = rtm::OutPort<RTM::TimedFloatSeq>;
  using InSeq = rtm::InPort<RTM::TimedFloatSeq>;
  PortableServer::Servant_var<OutSeq> out = new OutSeq("out0", "sensor0", through_ring());
  PortableServer::Servant_var<InSeq> in = new InSeq("in0", "controller0");
  RTM::InPortEx_var ref = in->activate(orb());
  ASSERT_TRUE(out->subscribe(RTM::repeated, ref.in()));
  RTM::SubscriptionInfoList_var subs = out->subscriptions();
  EXPECT_STREQ(subs[0].path.in(), "CORBA");
  out->close();
  in->deactivate();
}

TEST_F(ShmPortTest, AnInPortRefusesARingOfAnotherHostTypeOrNameAndSaysWhy) {
  auto in = make_in();
  RTM::InPortEx_var ref = in->activate(orb());
  RTM::InPortShm_var shm = RTM::InPortShm::_narrow(ref.in());
  ASSERT_FALSE(CORBA::is_nil(shm));
  const std::string host = rtm::shm_host_identity();
  const auto id = rtm::ring_type_id<RTM::TimedFloat6>();
  const rtm::ShmRingShape shape{16, sizeof(RTM::TimedFloat6), id};
  rtm::ShmSegment segment = rtm::ShmSegment::create(rtm::shm_ring_bytes(shape), "test.ring");
  rtm::ShmRingWriter writer(segment.data(), segment.size(), shape);
  auto refusal = [&](const std::string& name, const std::string& at, std::uint64_t type) {
    CORBA::String_var why;
    const bool taken = shm->attach_ring(name.c_str(), at.c_str(), type, getpid(), 0, why.out());
    return taken ? std::string("attached") : std::string(why.in());
  };
  EXPECT_EQ(refusal(segment.name(), "another-boot/net:1", id), "the publisher runs on another host or network namespace");
  EXPECT_EQ(refusal(segment.name(), host, id + 1), "the ring carries another data type");
  EXPECT_NE(refusal("../../etc/passwd", host, id).find("is not a shared-memory segment's name"), std::string::npos);
  EXPECT_NE(refusal("gone.1.1.1.shm", host, id).find("cannot open"), std::string::npos);
  EXPECT_EQ(in->attached_rings(), 0u);
  EXPECT_EQ(refusal(segment.name(), host, id), "attached");
  EXPECT_EQ(in->attached_rings(), 1u);
  EXPECT_TRUE(shm->detach_ring(segment.name().c_str()));
  EXPECT_FALSE(shm->detach_ring(segment.name().c_str()));
  in->deactivate();
}

TEST_F(ShmPortTest, ASecondSubscribeOfTheSamePortIsRefusedAndTheFirstKeepsReading) {
  auto [out, in, ref] = wired(rtm::InPortPolicy::fifo(8));
  EXPECT_FALSE(out->subscribe(RTM::repeated, ref.in()));
  EXPECT_EQ(in->attached_rings(), 1u);
  out->write(float6(4.0f));
  RTM::TimedFloat6 got{};
  ASSERT_EQ(in->read(got), ReadResult::NewData);
  EXPECT_FLOAT_EQ(got.val[0], 4.0f);
  out->close();
  EXPECT_EQ(in->attached_rings(), 0u) << "close() detached the subscriber";
  in->deactivate();
}

}  // namespace
