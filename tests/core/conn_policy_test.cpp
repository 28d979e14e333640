// SPDX-License-Identifier: Apache-2.0
// One connection policy per subscription (rtm/conn_policy.h): an OutPort whose subscriptions
// each follow their own depth, delivery, reader and path.
#include "core_test_support.h"

#include "rtm/conn_policy.h"
#include "rtm/outport.h"

#include <gtest/gtest.h>

#include <atomic>
#include <mutex>
#include <string>
#include <vector>

namespace {

using rtm::ConnPolicy;
using rtm::test::eventually;
using rtm::test::float6;

using rtm::test::In6;
using rtm::test::Out6;

class ConnPolicyPortTest : public rtm::test::OrbTest {
 protected:
  static rtm::OutPortOptions through(bool shared_memory) {
    rtm::OutPortOptions o;
    o.in_process = false;  // InPorts of this process are then reached as another process's
    o.shared_memory = shared_memory;
    return o;
  }
  static RTM::SubscriptionInfo only_subscription(RTM::OutPortEx_ptr out, const char* peer) {
    RTM::SubscriptionInfoList_var subs = out->subscriptions();
    for (CORBA::ULong i = 0; i < subs->length(); ++i)
      if (std::string(subs[i].peer.in()) == peer) return subs[i];
    ADD_FAILURE() << "no subscription of " << peer;
    return {};
  }
};

// Two subscribers stuck in their first datum while 2..10 are written: each gets back the newest
// data its own depth holds, not the port's.
TEST_F(ConnPolicyPortTest, EachSubscriptionFallsBehindByItsOwnDepth) {
  std::atomic<bool> release{false};
  struct ReleaseOnExit {
    std::atomic<bool>& flag;
    ~ReleaseOnExit() { flag = true; }
  } release_on_exit{release};
  std::mutex mu;
  std::vector<float> got2, got6;
  const auto stuck = [&](std::vector<float>& into) {
    return rtm::InPortPolicy::callback<RTM::TimedFloat6>([&](const RTM::TimedFloat6& d) {
      {
        std::lock_guard lock(mu);
        into.push_back(d.val[0]);
      }
      while (!release.load()) std::this_thread::sleep_for(std::chrono::microseconds(200));
    });
  };
  PortableServer::Servant_var<Out6> out = new Out6("out0", "src");  // queue_depth 8
  PortableServer::Servant_var<In6> two = new In6("two", "dst", stuck(got2));
  PortableServer::Servant_var<In6> six = new In6("six", "dst", stuck(got6));
  RTM::OutPortEx_var out_ref = out->activate(orb());
  RTM::InPortEx_var two_ref = two->activate(orb());
  RTM::InPortEx_var six_ref = six->activate(orb());
  ASSERT_TRUE(out_ref->connect(rtm::to_idl(rtm::parse_conn_policy("depth=2")), two_ref.in())) << out->last_error_text();
  ASSERT_TRUE(out_ref->connect(rtm::to_idl(rtm::parse_conn_policy("depth=6")), six_ref.in())) << out->last_error_text();
  const auto count = [&](std::vector<float>& v) {
    std::lock_guard lock(mu);
    return v.size();
  };
  out->write(float6(1.0f));
  ASSERT_TRUE(eventually([&] { return count(got2) == 1 && count(got6) == 1; }));
  for (int i = 2; i <= 10; ++i) out->write(float6(static_cast<float>(i)));
  release = true;
  ASSERT_TRUE(eventually([&] { return count(got2) == 3 && count(got6) == 7; }));
  {
    std::lock_guard lock(mu);
    EXPECT_EQ(got2, (std::vector<float>{1, 9, 10}));
    EXPECT_EQ(got6, (std::vector<float>{1, 5, 6, 7, 8, 9, 10}));
  }
  EXPECT_EQ(only_subscription(out_ref.in(), "dst.two").policy.depth, 2u);
  EXPECT_EQ(only_subscription(out_ref.in(), "dst.six").dropped, 3u);
  out->close();
  two->deactivate();
  six->deactivate();
  out->deactivate();
}

// On one port, write() calls one subscriber itself and leaves the other to its thread.
TEST_F(ConnPolicyPortTest, WhoMakesTheCallIsChosenPerSubscription) {
  // No bound on write()'s own calls: under a sanitizer a call may take longer than the 2 ms
  // default, and write() would then rightly leave it to the thread; who calls is what is tested.
  rtm::OutPortOptions options = through(false);
  options.writer_call_timeout_ms = 0;
  PortableServer::Servant_var<Out6> out = new Out6("out0", "src", options);
  PortableServer::Servant_var<In6> by_writer = new In6("by_writer", "dst");
  PortableServer::Servant_var<In6> by_thread = new In6("by_thread", "dst");
  RTM::OutPortEx_var out_ref = out->activate(orb());
  RTM::InPortEx_var w_ref = by_writer->activate(orb());
  RTM::InPortEx_var t_ref = by_thread->activate(orb());
  ASSERT_TRUE(out_ref->connect(rtm::to_idl(rtm::parse_conn_policy("delivery=writer")), w_ref.in()));
  ASSERT_TRUE(out_ref->connect(rtm::to_idl(rtm::parse_conn_policy("delivery=thread")), t_ref.in()));
  for (int i = 1; i <= 10; ++i) {
    out->write(float6(static_cast<float>(i)));
    ASSERT_TRUE(eventually([&] {
      return by_writer->counters_snapshot().accepted == static_cast<std::uint64_t>(i) &&
             by_thread->counters_snapshot().accepted == static_cast<std::uint64_t>(i);
    }));
  }
  ASSERT_TRUE(eventually([&] { return out->counters_snapshot().pushed == 20; }));
  EXPECT_EQ(out->counters_snapshot().by_writer, 10u) << "the writer called one subscriber, never the other";
  const RTM::SubscriptionInfo w = only_subscription(out_ref.in(), "dst.by_writer");
  const RTM::SubscriptionInfo t = only_subscription(out_ref.in(), "dst.by_thread");
  EXPECT_STREQ(w.kind.in(), "CORBA by writer");
  EXPECT_STREQ(t.kind.in(), "CORBA by thread");
  EXPECT_EQ(t.policy.delivery, RTM::DELIVERY_BY_THREAD);
  EXPECT_EQ(t.asked.depth, 0u) << "as asked: the port's depth";
  EXPECT_EQ(t.policy.depth, 8u) << "as it is: the port's depth filled in";
  EXPECT_EQ(t.policy.call_timeout_ms, 1000u);
  EXPECT_STREQ(t.reader.in(), "latest");
  out->close();
  by_writer->deactivate();
  by_thread->deactivate();
  out->deactivate();
}

TEST_F(ConnPolicyPortTest, AReaderPolicyTheInPortDoesNotKeepIsRefusedNamingBoth) {
  for (const bool in_process : {true, false}) {
    SCOPED_TRACE(in_process ? "in-process" : "through the ORB");
    rtm::OutPortOptions options = through(false);
    options.in_process = in_process;
    PortableServer::Servant_var<Out6> out = new Out6("out0", "src", options);
    PortableServer::Servant_var<In6> fifo = new In6("fifo", "dst", rtm::InPortPolicy::fifo(8));
    RTM::OutPortEx_var out_ref = out->activate(orb());
    RTM::InPortEx_var in_ref = fifo->activate(orb());
    EXPECT_FALSE(out->subscribe_with(rtm::parse_conn_policy("reader=latest"), in_ref.in()));
    EXPECT_NE(out->last_error_text().find("src.out0 -> dst.fifo: the InPort keeps fifo:8, the connection asks "
                                       "reader=latest"),
              std::string::npos)
        << out->last_error_text();
    EXPECT_FALSE(out->subscribe_with(rtm::parse_conn_policy("reader=fifo:16"), in_ref.in()));
    EXPECT_EQ(out->subscription_count(), 0u);
    ASSERT_TRUE(out->subscribe_with(rtm::parse_conn_policy("reader=fifo:8"), in_ref.in())) << out->last_error_text();
    out->write(float6(3.0f));
    ASSERT_TRUE(eventually([&] { return fifo->counters_snapshot().accepted == 1; }));
    EXPECT_STREQ(only_subscription(out_ref.in(), "dst.fifo").kind.in(), in_process ? "in-process" : "CORBA by writer");
    out->close();
    fifo->deactivate();
    out->deactivate();
  }
}

TEST_F(ConnPolicyPortTest, PathCorbaAndADepthBeyondTheRingKeepASameHostSubscriberOffTheRing) {
  PortableServer::Servant_var<Out6> out = new Out6("out0", "src", through(true));
  PortableServer::Servant_var<In6> ring = new In6("ring", "dst");
  PortableServer::Servant_var<In6> corba = new In6("corba", "dst");
  PortableServer::Servant_var<In6> deep = new In6("deep", "dst");
  RTM::OutPortEx_var out_ref = out->activate(orb());
  RTM::InPortEx_var ring_ref = ring->activate(orb());
  RTM::InPortEx_var corba_ref = corba->activate(orb());
  RTM::InPortEx_var deep_ref = deep->activate(orb());
  ASSERT_TRUE(out->subscribe_with(ConnPolicy::repeated(), ring_ref.in()));
  ASSERT_TRUE(out->subscribe_with(rtm::parse_conn_policy("path=corba"), corba_ref.in()));
  ASSERT_TRUE(out->subscribe_with(rtm::parse_conn_policy("depth=4096"), deep_ref.in()));  // the ring has 256
  EXPECT_STREQ(only_subscription(out_ref.in(), "dst.ring").kind.in(), "shared memory");
  EXPECT_STREQ(only_subscription(out_ref.in(), "dst.corba").kind.in(), "CORBA by writer");
  EXPECT_STREQ(only_subscription(out_ref.in(), "dst.deep").kind.in(), "CORBA by writer");
  EXPECT_FALSE(out->subscribe_with(rtm::parse_conn_policy("depth=4096"), ring_ref.in()))
      << "one subscription per InPort, whatever its policy";
  out->write(float6(5.0f));
  RTM::TimedFloat6 d{};
  ASSERT_TRUE(eventually([&] { return ring->read(d) == rtm::ReadResult::NewData; }));
  ASSERT_TRUE(eventually([&] { return corba->counters_snapshot().accepted == 1 && deep->counters_snapshot().accepted == 1; }));
  EXPECT_EQ(ring->counters_snapshot().shared_memory, 1u);
  EXPECT_EQ(corba->counters_snapshot().shared_memory, 0u);
  out->close();
  for (auto* in : {ring.in(), corba.in(), deep.in()}) in->deactivate();
  out->deactivate();
}

}  // namespace
