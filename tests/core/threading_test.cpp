// SPDX-License-Identifier: Apache-2.0
// Concurrency: subscriptions and component control changed while data flows (run under TSan).
#include "core_test_support.h"

#include <gtest/gtest.h>

#include <thread>

namespace {

using rtm::test::Doubler;
using rtm::test::eventually;
using rtm::test::float6;

class ThreadingTest : public rtm::test::OrbTest {};

using rtm::test::In6;
using rtm::test::Out6;

TEST_F(ThreadingTest, SubscribeAndUnsubscribeWhileWriting) {
  for (const int path : {0, 1, 2}) {
    const char* names[] = {"in-process", "shared memory", "CORBA"};
    SCOPED_TRACE(names[path]);
    rtm::OutPortOptions options;
    options.in_process = path == 0;
    options.shared_memory = path == 1;
    PortableServer::Servant_var<Out6> out = new Out6("out0", "sensor0", options);
    PortableServer::Servant_var<In6> a = new In6("a", "ctl", rtm::InPortPolicy::fifo(4));
    PortableServer::Servant_var<In6> b = new In6("b", "ctl");
    RTM::InPortEx_var a_ref = a->activate(orb());
    RTM::InPortEx_var b_ref = b->activate(orb());
    ASSERT_TRUE(out->subscribe(RTM::repeated, b_ref.in()));  // stays subscribed throughout

    std::atomic<bool> stop{false};
    std::thread writer([&] {
      float v = 0;
      while (!stop) out->write(float6(v += 1.0f));
    });
    std::thread reader([&] {
      RTM::TimedFloat6 d{};
      while (!stop) {
        a->read(d);
        RTM::SubscriptionInfoList_var subs = out->subscriptions();
        // An introspection client, not a second writer: without a pause it can hog the
        // port's mutex (glibc mutexes are not fair) and starve the writer in this test.
        std::this_thread::sleep_for(std::chrono::microseconds(50));
      }
    });
    int subscribed = 0;
    for (int i = 0; i < 200; ++i) {
      if (out->subscribe(i % 3 == 0 ? RTM::once : RTM::repeated, a_ref.in())) ++subscribed;
      std::this_thread::yield();
      out->unsubscribe(RTM::repeated, a_ref.in());
      out->unsubscribe(RTM::once, a_ref.in());
    }
    // The writer really ran concurrently (and still does).
    const std::uint64_t written_then = out->counters_snapshot().written;
    ASSERT_TRUE(eventually([&] { return out->counters_snapshot().written > written_then + 100; }));
    stop = true;
    writer.join();
    reader.join();
    EXPECT_EQ(subscribed, 200);  // every unsubscribe (or once-delivery) made room for the next
    ASSERT_TRUE(eventually([&] { return out->subscription_count() == 1; }));
    EXPECT_GT(b->counters_snapshot().accepted, 0u) << "written " << out->counters_snapshot().written << " pushed "
                                                   << out->counters_snapshot().pushed << " failed "
                                                   << out->counters_snapshot().failed;
    out->close();
    a->deactivate();
    b->deactivate();
  }
}

TEST_F(ThreadingTest, OnOffAndStateFromSeveralThreads) {
  auto logic = std::make_unique<Doubler>();
  rtm::ComponentServant servant(std::move(logic), [] {
    rtm::PeriodicOptions o;
    o.period_ns = 500'000;
    return o;
  }());
  RTM::RtComponentEx_var ref = servant.activate(orb());
  std::vector<std::thread> threads;
  for (int t = 0; t < 3; ++t)
    threads.emplace_back([&, t] {
      for (int i = 0; i < 50; ++i) {
        if ((i + t) % 2 == 0) ref->on();
        else ref->off();
        (void)ref->state();
        (void)ref->timing();
      }
    });
  for (auto& th : threads) th.join();
  ref->off();
  EXPECT_EQ(ref->state(), RTM::COMPONENT_OFF);
}

TEST_F(ThreadingTest, PutsFromManyThreadsAreAllCounted) {
  PortableServer::Servant_var<In6> in = new In6("in0", "ctl", rtm::InPortPolicy::fifo(8));
  RTM::InPortEx_var ref = in->activate(orb());
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&] {
      CORBA::Any a;
      a <<= float6(1.0f);
      for (int i = 0; i < 500; ++i) ref->put(a);
    });
  std::atomic<bool> stop{false};
  std::uint64_t read_count = 0;
  std::thread reader([&] {
    RTM::TimedFloat6 d{};
    while (!stop)
      if (in->read(d) == rtm::ReadResult::NewData) ++read_count;
  });
  for (auto& th : threads) th.join();
  stop = true;
  reader.join();
  const auto c = in->counters_snapshot();
  // Drop-oldest accepts every datum and evicts an older one when full.
  EXPECT_EQ(c.accepted, 2000u);
  EXPECT_EQ(read_count + in->queued() + c.dropped, 2000u);
  in->deactivate();
}

}  // namespace
