// SPDX-License-Identifier: Apache-2.0
// Subscriptions changed from other threads while a component publishes: the publisher and a
// steady subscriber must not notice.
#include "integration_fixture.h"

#include "rtm/inport.h"

#include <atomic>

namespace rtm_it {
namespace {

using Float6In = rtm::InPort<RTM::TimedFloat6>;

TEST_F(IntegrationTest, SubscribeUnsubscribeHammeredFromTwoThreadsWhileRunning) {
  start_component("pub0", {"--on"});
  auto out = out_port("pub0", "out0");

  PortableServer::Servant_var<Float6In> steady(new Float6In("steady", "itest"));
  RTM::InPortEx_var steady_ref = steady->activate(orb());
  ASSERT_TRUE(out->subscribe(RTM::repeated, steady_ref));

  std::atomic<bool> stop{false};
  std::atomic<int> errors{0};
  std::atomic<std::uint64_t> rounds{0};
  auto hammer = [&](const char* name) {
    PortableServer::Servant_var<Float6In> port(new Float6In(name, "itest"));
    RTM::InPortEx_var ref = port->activate(orb());
    while (!stop.load()) {
      try {
        const bool subscribed = out->subscribe(rounds % 3 == 0 ? RTM::once : RTM::repeated, ref);
        out->unsubscribe(RTM::repeated, ref);
        out->unsubscribe(RTM::once, ref);
        if (!subscribed) ++errors;
        ++rounds;
      } catch (const CORBA::Exception&) {
        ++errors;
      }
    }
    port->deactivate();
  };
  std::thread first(hammer, "hammer1");
  std::thread second(hammer, "hammer2");
  const auto steady_before = steady->counters_snapshot().accepted;
  // Until both sides made progress: hundreds of subscription changes, and the steady
  // subscriber receiving through them.
  const bool hammered = eventually(
      [&] { return rounds.load() >= 400 && steady->counters_snapshot().accepted >= steady_before + 100; }, 60s);
  stop = true;
  first.join();
  second.join();
  ASSERT_TRUE(hammered) << rounds.load() << " rounds, steady subscriber got "
                        << steady->counters_snapshot().accepted - steady_before;
  EXPECT_EQ(errors.load(), 0);

  // The steady subscriber is the only subscription left.
  RTM::SubscriptionInfoList_var subs = out->subscriptions();
  ASSERT_EQ(subs->length(), 1u);
  EXPECT_EQ(std::string(subs[0].peer.in()), "itest.steady");
  EXPECT_EQ(component("pub0")->state(), RTM::COMPONENT_ON);
  out->unsubscribe(RTM::repeated, steady_ref);
  steady->deactivate();
}

}  // namespace
}  // namespace rtm_it
