// SPDX-License-Identifier: Apache-2.0
#include "core_test_support.h"

#include "rtm/outport.h"

#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <fstream>
#include <map>
#include <mutex>
#include <thread>
#include <vector>

namespace {

using rtm::ReadResult;
using namespace rtm::test;  // eventually, float6, In6, Out6, OrbTest

enum class Path { in_process, shared_memory, corba };

class OutPortTest : public rtm::test::OrbTest {
 protected:
  void deliver_to_another_process(Path path);
  PortableServer::Servant_var<Out6> make_out(rtm::OutPortOptions options = {}) {
    return new Out6("out0", "sensor0", options);
  }
  PortableServer::Servant_var<In6> make_in(const char* name = "in0",
                                           rtm::InPortPolicy policy = rtm::InPortPolicy::latest()) {
    return new In6(name, "controller0", std::move(policy));
  }
};

// Through the ORB although the subscriber is in this process: neither in-process nor through
// shared memory.
rtm::OutPortOptions via_orb() {
  rtm::OutPortOptions o;
  o.in_process = false;
  o.shared_memory = false;
  return o;
}

// The three paths a subscription can take to an InPort of this process, as they would to one
// of another process on this host.
const char* path_name(Path p) {
  return p == Path::in_process ? "in-process" : p == Path::shared_memory ? "shared memory" : "CORBA";
}
rtm::OutPortOptions options_for(Path p) {
  rtm::OutPortOptions o;
  o.in_process = p == Path::in_process;
  o.shared_memory = p == Path::shared_memory;
  return o;
}

TEST_F(OutPortTest, GetBeforeTheFirstWriteRaisesBadInvOrderThenReturnsTheLatest) {
  auto out = make_out();
  RTM::OutPortEx_var ref = out->activate(orb());
  try {
    CORBA::Any_var nothing = ref->get();
    FAIL() << "get before the first write returned";
  } catch (const CORBA::BAD_INV_ORDER& e) {
    EXPECT_EQ(e.minor(), rtm::kMinorNoDataYet);
  }
  out->write(float6(1.0f));
  out->write(float6(7.0f));
  CORBA::Any_var got = ref->get();
  const RTM::TimedFloat6* d = nullptr;
  ASSERT_TRUE(got.in() >>= d);
  EXPECT_FLOAT_EQ(d->val[0], 7.0f);
  EXPECT_EQ(ref->counters().accepted, 2u);
  out->deactivate();
}

TEST_F(OutPortTest, AttributesNameTypeAndOwner) {
  auto out = make_out();
  RTM::OutPortEx_var ref = out->activate(orb());
  CORBA::String_var name = ref->name();
  CORBA::String_var owner = ref->owner();
  CORBA::TypeCode_var type = ref->port_type();
  EXPECT_STREQ(name.in(), "out0");
  EXPECT_STREQ(owner.in(), "sensor0");
  EXPECT_TRUE(type->equivalent(RTM::_tc_TimedFloat6));
  out->deactivate();
}

TEST_F(OutPortTest, InProcessSubscriberIsFedWithoutTheAnyPath) {
  auto out = make_out();
  auto in = make_in();
  RTM::OutPortEx_var out_ref = out->activate(orb());
  RTM::InPortEx_var in_ref = in->activate(orb());
  ASSERT_TRUE(out_ref->subscribe(RTM::repeated, in_ref.in()));
  RTM::SubscriptionInfoList_var subs = out_ref->subscriptions();
  ASSERT_EQ(subs->length(), 1u);
  EXPECT_TRUE(subs[0].in_process);
  EXPECT_STREQ(subs[0].peer.in(), "controller0.in0");
  for (int i = 1; i <= 5; ++i) out->write(float6(static_cast<float>(i)));
  // Delivered synchronously by write(): no waiting needed.
  const auto c = in->counters_snapshot();
  EXPECT_EQ(c.accepted, 5u);
  EXPECT_EQ(c.in_process, 5u);
  RTM::TimedFloat6 got{};
  ASSERT_EQ(in->read(got), ReadResult::NewData);
  EXPECT_FLOAT_EQ(got.val[0], 5.0f);
  EXPECT_EQ(out->counters_snapshot().pushed, 5u);
  in->deactivate();
  out->deactivate();
}

TEST_F(OutPortTest, WithInProcessOffTheSameSubscriberGetsPutAny) {
  auto out = make_out(via_orb());
  auto in = make_in("in0", rtm::InPortPolicy::fifo(16));
  RTM::InPortEx_var in_ref = in->activate(orb());
  ASSERT_TRUE(out->subscribe(RTM::repeated, in_ref.in()));
  RTM::SubscriptionInfoList_var subs = out->subscriptions();
  ASSERT_EQ(subs->length(), 1u);
  EXPECT_FALSE(subs[0].in_process);
  out->write(float6(1.0f));
  ASSERT_TRUE(eventually([&] { return in->counters_snapshot().accepted == 1; }));
  EXPECT_EQ(in->counters_snapshot().in_process, 0u);
  out->close();
  in->deactivate();
}

TEST_F(OutPortTest, OnewayOptionStillDeliversEveryDatum) {
  rtm::OutPortOptions options = via_orb();
  options.oneway = true;
  auto out = make_out(options);
  auto in = make_in("in0", rtm::InPortPolicy::fifo(8));
  RTM::InPortEx_var in_ref = in->activate(orb());
  ASSERT_TRUE(out->subscribe(RTM::repeated, in_ref.in()));
  for (std::uint64_t i = 1; i <= 3; ++i) {
    out->write(float6(static_cast<float>(i)));
    ASSERT_TRUE(eventually([&] { return in->counters_snapshot().accepted == i; }));
  }
  EXPECT_EQ(in->counters_snapshot().in_process, 0u);
  EXPECT_EQ(out->counters_snapshot().pushed, 3u);
  out->close();
  in->deactivate();
}

TEST_F(OutPortTest, RepeatedPushesEveryDatumOnceTakesOnlyTheNext) {
  for (Path path : {Path::in_process, Path::shared_memory, Path::corba}) {
    SCOPED_TRACE(path_name(path));
    auto out = make_out(options_for(path));
    auto every = make_in("every", rtm::InPortPolicy::fifo(64));
    auto next = make_in("next", rtm::InPortPolicy::fifo(64));
    RTM::InPortEx_var every_ref = every->activate(orb());
    RTM::InPortEx_var next_ref = next->activate(orb());
    ASSERT_TRUE(out->subscribe(RTM::repeated, every_ref.in()));
    ASSERT_TRUE(out->subscribe(RTM::once, next_ref.in()));
    for (int i = 1; i <= 4; ++i) {
      out->write(float6(static_cast<float>(i)));
      // One at a time, so the slow path cannot coalesce them.
      ASSERT_TRUE(eventually([&] { return every->counters_snapshot().accepted == static_cast<std::uint64_t>(i); }));
    }
    ASSERT_TRUE(eventually([&] { return out->subscription_count() == 1; }));
    EXPECT_EQ(next->counters_snapshot().accepted, 1u);
    RTM::TimedFloat6 got{};
    ASSERT_EQ(next->read(got), ReadResult::NewData);
    EXPECT_FLOAT_EQ(got.val[0], 1.0f);
    for (float expected : {1.0f, 2.0f, 3.0f, 4.0f}) {
      ASSERT_EQ(every->read(got), ReadResult::NewData);
      EXPECT_FLOAT_EQ(got.val[0], expected);
    }
    out->close();
    every->deactivate();
    next->deactivate();
  }
}

TEST_F(OutPortTest, OnceThroughTheOrbDeliversTheFirstDatumAfterSubscribing) {
  auto out = make_out(via_orb());
  auto in = make_in("in0", rtm::InPortPolicy::fifo(8));
  RTM::InPortEx_var in_ref = in->activate(orb());
  out->write(float6(0.0f));  // before the subscription: not for it
  ASSERT_TRUE(out->subscribe(RTM::once, in_ref.in()));
  out->write(float6(1.0f));
  out->write(float6(2.0f));
  out->write(float6(3.0f));
  ASSERT_TRUE(eventually([&] { return out->subscription_count() == 0; }));
  EXPECT_EQ(in->counters_snapshot().accepted, 1u);
  RTM::TimedFloat6 got{};
  ASSERT_EQ(in->read(got), ReadResult::NewData);
  EXPECT_FLOAT_EQ(got.val[0], 1.0f);
  EXPECT_EQ(out->counters_snapshot().by_writer, 0u)
      << "its thread made the call, under the subscription's bound, not write() under its own";
  out->close();
  in->deactivate();
}

TEST_F(OutPortTest, SubscribeRefusesNilReference) {
  auto out = make_out();
  EXPECT_FALSE(out->subscribe(RTM::repeated, RTM::InPort::_nil()));
  EXPECT_EQ(out->last_error_text(), "sensor0.out0: nil InPort reference");
  EXPECT_EQ(out->counters_snapshot().refused, 1u);
  EXPECT_EQ(out->subscription_count(), 0u);
}

TEST_F(OutPortTest, SubscribeRefusesADuplicateOfEitherType) {
  auto out = make_out();
  auto in = make_in();
  RTM::InPortEx_var in_ref = in->activate(orb());
  ASSERT_TRUE(out->subscribe(RTM::repeated, in_ref.in()));
  EXPECT_FALSE(out->subscribe(RTM::repeated, in_ref.in()));
  EXPECT_EQ(out->last_error_text(), "sensor0.out0 -> controller0.in0: already subscribed");
  EXPECT_FALSE(out->subscribe(RTM::once, in_ref.in()));
  EXPECT_EQ(out->subscription_count(), 1u);
  EXPECT_EQ(out->counters_snapshot().refused, 2u);
  in->deactivate();
}

TEST_F(OutPortTest, SubscribeRefusesATypeMismatchNamingBothPortsAndTypes) {
  auto out = make_out();
  PortableServer::Servant_var<rtm::InPort<RTM::TimedFloat3>> in =
      new rtm::InPort<RTM::TimedFloat3>("in1", "controller0");
  RTM::OutPortEx_var out_ref = out->activate(orb());
  RTM::InPortEx_var in_ref = in->activate(orb());
  EXPECT_FALSE(out_ref->subscribe(RTM::repeated, in_ref.in()));
  CORBA::String_var why = out_ref->last_error();
  EXPECT_STREQ(why.in(), "sensor0.out0 (RTM::TimedFloat6) -> controller0.in1 (RTM::TimedFloat3): types differ");
  EXPECT_EQ(out->subscription_count(), 0u);
  in->deactivate();
  out->deactivate();
}

TEST_F(OutPortTest, UnsubscribeRemovesOnlyAnExistingSubscriptionOfThatType) {
  auto out = make_out();
  auto in = make_in();
  RTM::InPortEx_var in_ref = in->activate(orb());
  EXPECT_FALSE(out->unsubscribe(RTM::repeated, in_ref.in()));
  EXPECT_FALSE(out->unsubscribe(RTM::repeated, RTM::InPort::_nil()));
  ASSERT_TRUE(out->subscribe(RTM::repeated, in_ref.in()));
  EXPECT_FALSE(out->unsubscribe(RTM::once, in_ref.in()));
  EXPECT_TRUE(out->unsubscribe(RTM::repeated, in_ref.in()));
  EXPECT_FALSE(out->unsubscribe(RTM::repeated, in_ref.in()));
  out->write(float6(1.0f));
  EXPECT_EQ(in->counters_snapshot().accepted, 0u);
  // And through the ORB path.
  auto slow = make_out(via_orb());
  ASSERT_TRUE(slow->subscribe(RTM::repeated, in_ref.in()));
  EXPECT_TRUE(slow->unsubscribe(RTM::repeated, in_ref.in()));
  EXPECT_EQ(slow->subscription_count(), 0u);
  in->deactivate();
}

TEST_F(OutPortTest, DeadSubscriberIsDroppedAfterMaxFailuresWhileWritingGoesOn) {
  for (Path path : {Path::in_process, Path::corba}) {  // shared memory: below
    SCOPED_TRACE(path_name(path));
    rtm::OutPortOptions options = options_for(path);
    options.max_failures = 3;
    auto out = make_out(options);
    auto dead = make_in("dead");
    auto alive = make_in("alive", rtm::InPortPolicy::fifo(64));
    RTM::InPortEx_var dead_ref = dead->activate(orb());
    RTM::InPortEx_var alive_ref = alive->activate(orb());
    ASSERT_TRUE(out->subscribe(RTM::repeated, dead_ref.in()));
    ASSERT_TRUE(out->subscribe(RTM::repeated, alive_ref.in()));
    dead->deactivate();  // its reference now raises OBJECT_NOT_EXIST
    // One datum at a time: through the ORB, data written faster than delivered may be skipped.
    for (std::uint64_t i = 1; i <= 6; ++i) {
      out->write(float6(static_cast<float>(i)));
      ASSERT_TRUE(eventually([&] { return alive->counters_snapshot().accepted == i; }));
      if (i <= 3) {
        ASSERT_TRUE(eventually([&] { return out->counters_snapshot().failed == i; }));
      }
    }
    ASSERT_TRUE(eventually([&] { return out->subscription_count() == 1; }));
    EXPECT_EQ(out->counters_snapshot().failed, 3u);
    EXPECT_EQ(out->counters_snapshot().written, 6u);
    EXPECT_EQ(dead->counters_snapshot().accepted, 0u);
    out->close();
    alive->deactivate();
  }
}

TEST_F(OutPortTest, CallbackSubscriberRunsOnADeliveryThreadNotTheWriter) {
  std::atomic<std::thread::id> callback_thread{};
  std::atomic<int> calls{0};
  auto out = make_out();
  auto in = make_in("in0", rtm::InPortPolicy::callback<RTM::TimedFloat6>([&](const RTM::TimedFloat6&) {
    callback_thread = std::this_thread::get_id();
    ++calls;
  }));
  RTM::InPortEx_var in_ref = in->activate(orb());
  ASSERT_TRUE(out->subscribe(RTM::repeated, in_ref.in()));
  RTM::SubscriptionInfoList_var subs = out->subscriptions();
  EXPECT_TRUE(subs[0].in_process);
  out->write(float6(1.0f));
  ASSERT_TRUE(eventually([&] { return calls.load() == 1; }));
  EXPECT_NE(callback_thread.load(), std::this_thread::get_id());
  EXPECT_EQ(in->counters_snapshot().in_process, 1u);
  out->close();
  in->deactivate();
}

TEST_F(OutPortTest, DirectConnectNeedsNoOrb) {
  Out6 out("out0", "sensor0");
  PortableServer::Servant_var<In6> in = new In6("in0", "controller0");
  ASSERT_TRUE(out.connect(*in));
  EXPECT_FALSE(out.connect(*in));
  out.write(float6(3.0f));
  RTM::TimedFloat6 got{};
  ASSERT_EQ(in->read(got), ReadResult::NewData);
  EXPECT_FLOAT_EQ(got.val[0], 3.0f);
  EXPECT_TRUE(out.disconnect(*in));
  EXPECT_FALSE(out.disconnect(*in));
  out.write(float6(4.0f));
  EXPECT_EQ(in->read(got), ReadResult::OldData);
}

// A subscriber stuck in its first delivery while the writer writes 2..10: with a ring of
// `depth` data it later receives the newest `depth` of them, oldest first; the rest are
// counted as dropped, and the fast subscriber beside it is never delayed.
class SlowSubscriberTest : public OutPortTest {
 protected:
  void check_slow_subscriber(std::uint32_t depth);
};

void SlowSubscriberTest::check_slow_subscriber(std::uint32_t depth) {
  std::atomic<bool> release{false};
  std::vector<float> received;
  std::mutex received_mu;
  rtm::OutPortOptions options;
  options.queue_depth = depth;
  auto out = make_out(options);
  auto slow = make_in("slow", rtm::InPortPolicy::callback<RTM::TimedFloat6>([&](const RTM::TimedFloat6& d) {
    {
      std::lock_guard lock(received_mu);
      received.push_back(d.val[0]);
    }
    while (!release.load()) std::this_thread::sleep_for(std::chrono::microseconds(200));
  }));
  auto fast = make_in("fast", rtm::InPortPolicy::fifo(64));
  struct ReleaseOnExit {
    std::atomic<bool>& flag;
    ~ReleaseOnExit() { flag = true; }
  } release_on_exit{release};  // a failed assertion must not leave close() joining a stuck thread
  RTM::InPortEx_var slow_ref = slow->activate(orb());
  RTM::InPortEx_var fast_ref = fast->activate(orb());
  ASSERT_TRUE(out->subscribe(RTM::repeated, slow_ref.in()));
  ASSERT_TRUE(out->subscribe(RTM::repeated, fast_ref.in()));
  auto received_count = [&] {
    std::lock_guard lock(received_mu);
    return received.size();
  };
  out->write(float6(1.0f));
  ASSERT_TRUE(eventually([&] { return received_count() == 1; }));  // the slow one is now stuck
  for (int i = 2; i <= 10; ++i) out->write(float6(static_cast<float>(i)));
  EXPECT_EQ(fast->counters_snapshot().accepted, 10u);  // never delayed by the slow one
  release = true;
  const std::size_t kept = std::min<std::size_t>(depth, 9);
  ASSERT_TRUE(eventually([&] { return received_count() == 1 + kept; }));
  std::vector<float> expected{1.0f};
  for (int i = static_cast<int>(10 - kept + 1); i <= 10; ++i) expected.push_back(static_cast<float>(i));
  {
    std::lock_guard lock(received_mu);
    EXPECT_EQ(received, expected) << "the newest data, oldest first";
  }
  EXPECT_EQ(out->counters_snapshot().dropped, 9u - kept);
  out->close();
  slow->deactivate();
  fast->deactivate();
}

TEST_F(SlowSubscriberTest, WithARingOfOneGetsOnlyTheNewest) { check_slow_subscriber(1); }

TEST_F(SlowSubscriberTest, CatchesUpFromItsRingAndLosesOnlyTheOldest) { check_slow_subscriber(4); }

TEST_F(SlowSubscriberTest, RingDeeperThanTheBacklogLosesNothing) { check_slow_subscriber(16); }

// ---- a reference from another process is never taken for a local one ----

class PeerProcess {
 public:
  PeerProcess() {
    int to_child[2], from_child[2];
    if (pipe(to_child) != 0 || pipe(from_child) != 0) throw std::runtime_error("pipe failed");
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, to_child[0], 0);
    posix_spawn_file_actions_adddup2(&actions, from_child[1], 1);
    posix_spawn_file_actions_addclose(&actions, to_child[1]);
    posix_spawn_file_actions_addclose(&actions, from_child[0]);
    char* argv[] = {const_cast<char*>(RTM_TEST_PEER), nullptr};
    const int err = posix_spawn(&pid_, RTM_TEST_PEER, &actions, nullptr, argv, environ);
    posix_spawn_file_actions_destroy(&actions);
    close(to_child[0]);
    close(from_child[1]);
    stdin_fd_ = to_child[1];
    stdout_fd_ = from_child[0];
    if (err != 0) throw std::runtime_error(std::string("cannot start ") + RTM_TEST_PEER);
  }
  ~PeerProcess() {
    close(stdin_fd_);  // the peer exits on EOF
    close(stdout_fd_);
    if (eventually([&] { return waitpid(pid_, nullptr, WNOHANG) == pid_; }, std::chrono::seconds(5))) return;
    kill(pid_, SIGKILL);
    waitpid(pid_, nullptr, 0);
  }
  // Its ORB answers nothing until resume(); returns once the kernel has stopped it.
  void pause() {
    kill(pid_, SIGSTOP);
    const std::string stat = "/proc/" + std::to_string(pid_) + "/stat";
    const auto stopped = [&] {
      std::ifstream in(stat);
      std::string pid, comm, state;
      in >> pid >> comm >> state;
      return state == "T";
    };
    if (!eventually(stopped)) throw std::runtime_error("the peer did not stop");
  }
  void resume() { kill(pid_, SIGCONT); }
  // The IOR the peer printed (empty if it printed nothing within 20 s).
  std::string read_ior() {
    std::string line;
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (std::chrono::steady_clock::now() < give_up) {
      pollfd p{stdout_fd_, POLLIN, 0};
      if (poll(&p, 1, 100) <= 0) continue;
      char c;
      if (read(stdout_fd_, &c, 1) != 1) break;
      if (c == '\n') return line;
      line += c;
    }
    return {};
  }

 private:
  pid_t pid_ = -1;
  int stdin_fd_ = -1;
  int stdout_fd_ = -1;
};

// A process of this host and this user: through the ring by default, through the ORB when the
// OutPort is told not to use shared memory.
TEST_F(OutPortTest, InPortOfAnotherProcessIsDeliveredThroughSharedMemoryOrTheOrb) {
  for (Path path : {Path::shared_memory, Path::corba}) {
    SCOPED_TRACE(path_name(path));
    deliver_to_another_process(path);
  }
}

void OutPortTest::deliver_to_another_process(Path path) {
  PeerProcess peer;
  const std::string ior = peer.read_ior();
  ASSERT_EQ(ior.rfind("IOR:", 0), 0u) << "peer printed '" << ior << "'";
  CORBA::Object_var obj = orb().from_string(ior);
  RTM::InPortEx_var remote = RTM::InPortEx::_narrow(obj);
  ASSERT_FALSE(CORBA::is_nil(remote));
  EXPECT_EQ(rtm::InPortBase::find_local(remote.in()).in(), nullptr);

  // A local port activated the same way (same POA name, likely the same object id).
  auto local_in = make_in();
  RTM::InPortEx_var local_ref = local_in->activate(orb());
  EXPECT_FALSE(local_ref->_is_equivalent(remote.in()));

  auto out = make_out(options_for(path));
  ASSERT_TRUE(out->subscribe(RTM::repeated, remote.in()));
  RTM::SubscriptionInfoList_var subs = out->subscriptions();
  ASSERT_EQ(subs->length(), 1u);
  EXPECT_FALSE(subs[0].in_process);
  EXPECT_STREQ(subs[0].path.in(), path_name(path));
  EXPECT_STREQ(subs[0].peer.in(), "peer0.in0");
  out->write(float6(5.0f));
  ASSERT_TRUE(eventually([&] { return remote->counters().accepted == 1; }));
  EXPECT_EQ(local_in->counters_snapshot().accepted, 0u);
  out->close();
  local_in->deactivate();
}

// ---- who makes the remote call: write() itself when the subscription is idle ----

struct Peer {
  PeerProcess process;
  RTM::InPortEx_var port;
  explicit Peer(rtm::Orb& orb) {
    const std::string ior = process.read_ior();
    if (ior.rfind("IOR:", 0) != 0) throw std::runtime_error("peer printed '" + ior + "'");
    CORBA::Object_var obj = orb.from_string(ior);
    port = RTM::InPortEx::_narrow(obj);
  }
  std::uint64_t accepted() { return port->counters().accepted; }
};

TEST_F(OutPortTest, AnIdleRemoteSubscriptionIsDeliveredByWriteItselfInOrder) {
  Peer peer(orb());
  auto out = make_out(options_for(Path::corba));  // Delivery::writer_when_idle is the default
  ASSERT_TRUE(out->subscribe(RTM::repeated, peer.port.in()));
  for (int i = 1; i <= 20; ++i) {
    out->write(float6(static_cast<float>(i)));
    ASSERT_TRUE(eventually([&] { return peer.accepted() == static_cast<std::uint64_t>(i); })) << "datum " << i;
  }
  const rtm::OutPortCounters c = out->counters_snapshot();
  EXPECT_EQ(c.pushed, 20u);
  EXPECT_EQ(c.by_writer, 20u) << "nothing was in flight before any write: write() made every call";
  EXPECT_EQ(c.failed, 0u) << "not even the first call outlived write()'s bound: the reference was warmed";
  const rtm::WriteCost cost = out->write_cost();
  EXPECT_EQ(cost.count, 20u) << "every write() that may call is measured";
  EXPECT_GT(cost.max_ns, 0);
  EXPECT_LE(cost.p50_ns, cost.p99_ns);
  out->close();
}

TEST_F(OutPortTest, WithDeliveryThreadWriteNeverCallsTheSubscriber) {
  Peer peer(orb());
  rtm::OutPortOptions options;
  options.shared_memory = false;  // the CORBA path (to InPorts of other processes)
  options.delivery = rtm::OutPortOptions::Delivery::thread;
  auto out = make_out(options);
  ASSERT_TRUE(out->subscribe(RTM::repeated, peer.port.in()));
  for (int i = 1; i <= 10; ++i) {
    out->write(float6(static_cast<float>(i)));
    ASSERT_TRUE(eventually([&] { return peer.accepted() == static_cast<std::uint64_t>(i); }));
  }
  // The subscriber counts a datum during the call, the publisher once the reply is back.
  ASSERT_TRUE(eventually([&] { return out->counters_snapshot().pushed == 10; }));
  EXPECT_EQ(out->counters_snapshot().by_writer, 0u);
  out->close();
}

TEST_F(OutPortTest, SubscribeToAnInPortThatNeverAnswersIsRefusedAfterTheCallTimeoutNotHeldForEver) {
  Peer peer(orb());
  rtm::OutPortOptions options;
  options.call_timeout_ms = 200;
  auto out = make_out(options);
  peer.process.pause();  // its ORB answers nothing: name(), owner(), port_type() would wait for ever
  EXPECT_FALSE(out->subscribe(RTM::repeated, peer.port.in()));
  EXPECT_NE(out->last_error_text().find("does not answer (TIMEOUT)"), std::string::npos) << out->last_error_text();
  peer.process.resume();
  EXPECT_TRUE(out->subscribe(RTM::repeated, peer.port.in())) << "once it answers: " << out->last_error_text();
  out->close();
}

TEST_F(OutPortTest, AnOutPortTakesAtMostMaxSubscriptionsAndRefusesMoreNamingTheLimit) {
  rtm::OutPortOptions options;
  options.max_subscriptions = 4;
  auto out = make_out(options);
  std::vector<PortableServer::Servant_var<In6>> ins;
  std::vector<RTM::InPortEx_var> refs;
  for (int i = 0; i < 5; ++i) {
    ins.push_back(make_in());
    refs.push_back(ins.back()->activate(orb()));
  }
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(out->subscribe(RTM::repeated, refs[i].in())) << i << out->last_error_text();
  EXPECT_FALSE(out->subscribe(RTM::repeated, refs[4].in()));
  EXPECT_NE(out->last_error_text().find("already 4 subscriptions, the most it takes"), std::string::npos)
      << out->last_error_text();
  EXPECT_EQ(out->counters_snapshot().refused, 1u);
  ASSERT_TRUE(out->unsubscribe(RTM::repeated, refs[0].in()));
  EXPECT_TRUE(out->subscribe(RTM::repeated, refs[4].in())) << "room again after an unsubscribe";
  out->close();
  for (auto& in : ins) in->deactivate();
}

// A subscriber that stops answering costs write() one bounded call: after it failed, the data
// go to the delivery thread (queued, oldest dropped past the ring), and write() calls again
// only once that thread has delivered. Nothing here is timed: the counters say who called.
TEST_F(OutPortTest, AStalledSubscriberCostsWriteOneFailedCallThenItsThreadTakesOver) {
  Peer peer(orb());
  rtm::OutPortOptions options;
  options.shared_memory = false;  // the CORBA path (to InPorts of other processes)
  options.call_timeout_ms = 60'000;   // the thread waits the stall out
  options.writer_call_timeout_ms = 5;  // write() does not
  auto out = make_out(options);
  ASSERT_TRUE(out->subscribe(RTM::repeated, peer.port.in()));
  out->write(float6(1.0f));
  ASSERT_TRUE(eventually([&] { return peer.accepted() == 1; }));
  ASSERT_EQ(out->counters_snapshot().by_writer, 1u);

  peer.process.pause();
  for (int i = 2; i <= 30; ++i) out->write(float6(static_cast<float>(i)));
  rtm::OutPortCounters c = out->counters_snapshot();
  EXPECT_EQ(c.failed, 1u) << "one call of write()'s timed out; the rest were queued, not called";
  EXPECT_EQ(c.timed_out, 1u) << "and that failure is told apart as a timeout (its datum's fate is unknown)";
  EXPECT_EQ(c.by_writer, 1u);
  EXPECT_EQ(out->subscription_count(), 1u) << "one failure does not drop a subscriber";

  peer.process.resume();
  // Every datum is accounted for once the thread has caught up: delivered (1, and what the
  // thread's ring held), failed (the call write() gave up), or dropped as stale. Whether the
  // thread's call in the stall was datum 3 or a later one depends on when it got the CPU.
  const auto accounted = [&] {
    const rtm::OutPortCounters now = out->counters_snapshot();
    return now.pushed + now.failed + now.dropped;
  };
  ASSERT_TRUE(eventually([&] { return accounted() == 30; })) << accounted();
  EXPECT_GE(out->counters_snapshot().pushed, 1u + 8) << "the ring's 8 newest reach the subscriber";
  // Then write() calls again.
  ASSERT_TRUE(eventually([&] {
    out->write(float6(99.0f));
    return out->counters_snapshot().by_writer > 1;
  }));
  c = out->counters_snapshot();
  EXPECT_EQ(c.failed, 1u);
  EXPECT_LE(c.dropped, 29u - 1 - 8) << "data 2..30: one failed in write(), 8 fit the ring";
  out->close();
}

// A once-subscription whose datum could not be delivered (the call timed out) is not spent:
// it takes the next datum, and is retired once one has gone through.
TEST_F(OutPortTest, AOnceSubscriptionWhoseDeliveryTimedOutDeliversTheNextDatum) {
  Peer peer(orb());
  rtm::OutPortOptions options;
  options.call_timeout_ms = 200;
  auto out = make_out(options);
  ASSERT_TRUE(out->subscribe(RTM::once, peer.port.in()));
  peer.process.pause();
  out->write(float6(1.0f));
  ASSERT_TRUE(eventually([&] { return out->counters_snapshot().timed_out == 1; }));
  EXPECT_EQ(out->subscription_count(), 1u) << "a failed delivery does not spend the subscription";
  peer.process.resume();
  ASSERT_TRUE(eventually([&] {
    out->write(float6(2.0f));
    return out->subscription_count() == 0;
  })) << "the next datum is taken, and the subscription retired once it has gone through";
  const rtm::OutPortCounters c = out->counters_snapshot();
  EXPECT_EQ(c.pushed, 1u);
  EXPECT_EQ(c.failed, 1u);
  EXPECT_EQ(c.by_writer, 0u);
  // Datum 1 may have reached the peer after its call timed out (before datum 2, or it is
  // dropped there as late); datum 2 did.
  const std::uint64_t accepted = peer.accepted();
  EXPECT_GE(accepted, 1u);
  EXPECT_LE(accepted, 2u);
  out->write(float6(3.0f));
  EXPECT_EQ(peer.accepted(), accepted) << "nothing after the subscription was spent";
  out->close();
}

// Over CORBA a failed call finds it out; through shared memory (no call per datum) the
// subscription's thread, which asks the subscriber every second whether it still exists.
TEST_F(OutPortTest, ASubscriberThatDiedIsDroppedWhetherWriteOrItsThreadFindsOut) {
  for (Path path : {Path::corba, Path::shared_memory}) {
    SCOPED_TRACE(path_name(path));
    auto peer = std::make_unique<Peer>(orb());
    auto out = make_out(options_for(path));
    ASSERT_TRUE(out->subscribe(RTM::repeated, peer->port.in()));
    RTM::SubscriptionInfoList_var subs = out->subscriptions();
    EXPECT_STREQ(subs[0].path.in(), path_name(path));
    out->write(float6(1.0f));
    ASSERT_TRUE(eventually([&] { return peer->accepted() == 1; }));
    peer.reset();  // the process exits: its endpoint refuses connections
    ASSERT_TRUE(eventually([&] {
      out->write(float6(2.0f));
      return out->subscription_count() == 0;
    }));
    EXPECT_GE(out->counters_snapshot().failed, 1u);
    out->close();
  }
}

// write() begins no call once its budget (writer_call_timeout_ms) is spent: behind a stalled
// subscriber, the next one gets the datum from its own thread.
TEST_F(OutPortTest, BehindACallThatUsedWritesBudgetTheNextSubscriberIsServedByItsThread) {
  Peer stalled(orb());
  Peer healthy(orb());
  rtm::OutPortOptions options;
  options.shared_memory = false;  // the CORBA path (to InPorts of other processes)
  options.call_timeout_ms = 60'000;
  options.writer_call_timeout_ms = 5;
  auto out = make_out(options);
  ASSERT_TRUE(out->subscribe(RTM::repeated, stalled.port.in()));  // called first
  ASSERT_TRUE(out->subscribe(RTM::repeated, healthy.port.in()));
  stalled.process.pause();
  out->write(float6(1.0f));
  ASSERT_TRUE(eventually([&] { return healthy.accepted() == 1; }));
  EXPECT_EQ(out->counters_snapshot().by_writer, 0u) << "the healthy subscriber's datum went through its thread";
  EXPECT_EQ(out->counters_snapshot().failed, 1u) << "the stalled one's call timed out";
  stalled.process.resume();
  out->close();
}

// A peer at the protocol level: an RTM::InPortOrdered that records what each call carried.
class OrderRecorder : public virtual POA_RTM::InPortOrdered {
 public:
  struct Call {
    std::uint64_t sender, seq;
    float first;
  };
  void put_in_order(const CORBA::Any& value, CORBA::ULongLong sender, CORBA::ULongLong seq) override {
    if (refuse_.load()) throw CORBA::NO_PERMISSION(rtm::kAccessRefusedMinor, CORBA::COMPLETED_NO);
    const RTM::TimedFloat6* d = nullptr;
    if (!(value >>= d)) throw CORBA::BAD_PARAM(0, CORBA::COMPLETED_NO);
    std::lock_guard lock(mu_);
    calls_.push_back({sender, seq, d->val[0]});
  }
  void push_in_order(const CORBA::Any& value, CORBA::ULongLong sender, CORBA::ULongLong seq) override {
    put_in_order(value, sender, seq);
  }
  void put(const CORBA::Any&) override { ++unordered_; }
  void push(const CORBA::Any&) override { ++unordered_; }
  char* name() override { return CORBA::string_dup("recorder"); }
  char* owner() override { return CORBA::string_dup("test"); }
  CORBA::TypeCode_ptr port_type() override { return CORBA::TypeCode::_duplicate(RTM::_tc_TimedFloat6); }
  RTM::PortCounters counters() override { return {}; }
  char* last_error() override { return CORBA::string_dup(""); }
  RTM::PortDescription* describe() override { return new RTM::PortDescription; }
  void admit_writer() override {}
  char* reader_policy() override { return CORBA::string_dup("fifo"); }

  std::vector<Call> calls() {
    std::lock_guard lock(mu_);
    return calls_;
  }
  std::atomic<int> unordered_{0};
  std::atomic<bool> refuse_{false};  // answer every datum as access control refuses one

 private:
  std::mutex mu_;
  std::vector<Call> calls_;
};

// To an InPortOrdered every datum goes with its subscription's sender number and its own
// rising number, whoever makes the call (write() or the delivery thread), so that the
// receiver can drop one that arrives late.
TEST_F(OutPortTest, AnOrderedSubscriberGetsEachDatumWithItsSenderAndRisingNumber) {
  PortableServer::Servant_var<OrderRecorder> recorder(new OrderRecorder);
  CORBA::Object_var obj = orb().activate(recorder.in());
  RTM::InPort_var ref = RTM::InPort::_narrow(obj);
  auto by_writer = make_out(via_orb());
  rtm::OutPortOptions threaded = via_orb();
  threaded.delivery = rtm::OutPortOptions::Delivery::thread;
  auto by_thread = make_out(threaded);
  ASSERT_TRUE(by_writer->subscribe(RTM::repeated, ref.in()));
  ASSERT_TRUE(by_thread->subscribe(RTM::repeated, ref.in()));
  for (int i = 1; i <= 10; ++i) {
    by_writer->write(float6(static_cast<float>(i)));
    by_thread->write(float6(static_cast<float>(100 + i)));
    ASSERT_TRUE(eventually([&] { return recorder->calls().size() == static_cast<std::size_t>(2 * i); }));
  }
  EXPECT_EQ(recorder->unordered_.load(), 0) << "no plain put to a port that keeps order";
  EXPECT_GT(by_writer->counters_snapshot().by_writer, 0u);
  std::map<std::uint64_t, std::vector<std::uint64_t>> seqs;
  for (const auto& c : recorder->calls()) {
    seqs[c.sender].push_back(c.seq);
    EXPECT_FLOAT_EQ(c.first, static_cast<float>(c.seq + (c.first > 100 ? 100 : 0))) << "datum and number match";
  }
  ASSERT_EQ(seqs.size(), 2u) << "each subscription has a sender number of its own";
  for (const auto& [sender, numbers] : seqs) {
    EXPECT_NE(sender, 0u);
    EXPECT_EQ(numbers, (std::vector<std::uint64_t>{1, 2, 3, 4, 5, 6, 7, 8, 9, 10}));
  }
  by_writer->close();
  by_thread->close();
  orb().deactivate(recorder.in());
}

// A subscription whose data are refused says so, and why, on its edge (`rtm ls -l`, the page),
// until a datum goes through again.
TEST_F(OutPortTest, ASubscriptionWhoseDataAreRefusedSaysWhyUntilOneGoesThrough) {
  PortableServer::Servant_var<OrderRecorder> recorder(new OrderRecorder);
  CORBA::Object_var obj = orb().activate(recorder.in());
  RTM::InPort_var ref = RTM::InPort::_narrow(obj);
  auto out = make_out(via_orb());
  ASSERT_TRUE(out->subscribe(RTM::repeated, ref.in()));
  const auto last_failure = [&] {
    RTM::SubscriptionInfoList_var subs = out->subscriptions();
    return subs->length() == 1 ? std::string(subs[0].last_failure.in()) : std::string("(no subscription)");
  };
  recorder->refuse_ = true;
  out->write(float6(1.0f));
  ASSERT_TRUE(eventually([&] { return out->counters_snapshot().failed > 0; }));
  EXPECT_EQ(last_failure(), "NO_PERMISSION: " + rtm::access_refusal_text(rtm::kAccessRefusedMinor));
  recorder->refuse_ = false;
  out->write(float6(2.0f));
  ASSERT_TRUE(eventually([&] { return out->counters_snapshot().pushed > 0; }));
  EXPECT_EQ(last_failure(), "");
  out->close();
  orb().deactivate(recorder.in());
}

// writer_call_timeout_ms = 0 takes the bound off write()'s calls (opt-in): behind a stalled
// subscriber write() waits until it answers, and the datum is delivered, not failed.
TEST_F(OutPortTest, WithoutAWriterBoundWriteWaitsOutAStalledSubscriberAndDelivers) {
  Peer peer(orb());
  rtm::OutPortOptions options;
  options.shared_memory = false;  // the CORBA path (to InPorts of other processes)
  options.writer_call_timeout_ms = 0;
  auto out = make_out(options);
  ASSERT_TRUE(out->subscribe(RTM::repeated, peer.port.in()));
  out->write(float6(1.0f));
  ASSERT_EQ(out->counters_snapshot().by_writer, 1u);

  peer.process.pause();
  std::atomic<bool> returned{false};
  std::thread writer([&] {
    out->write(float6(2.0f));
    returned = true;
  });
  // Far beyond the default 2 ms bound: with a bound write() would have given up by now.
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_FALSE(returned.load()) << "write() gave up on a stalled subscriber although no bound was set";
  peer.process.resume();
  writer.join();
  const rtm::OutPortCounters c = out->counters_snapshot();
  EXPECT_EQ(c.by_writer, 2u) << "write() delivered the datum itself once the subscriber answered";
  EXPECT_EQ(c.failed, 0u);
  EXPECT_EQ(peer.accepted(), 2u);
  out->close();
}

}  // namespace
