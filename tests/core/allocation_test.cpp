// SPDX-License-Identifier: Apache-2.0
#include "rtm_test/allocation_counter.h"

#include "rt/clock.h"
#include "rtm/component.h"
#include "rtm/data.h"
#include "rtm/inport.h"
#include "rtm/outport.h"

#include <gtest/gtest.h>

namespace {

TEST(Allocation, WriteAndReadOfAFixedSizeTypeAllocateNothing) {
  using In6 = rtm::InPort<RTM::TimedFloat6>;
  PortableServer::Servant_var<In6> latest = new In6("latest", "ctl");
  PortableServer::Servant_var<In6> fifo = new In6("fifo", "ctl", rtm::InPortPolicy::fifo(4, rtm::FullPolicy::DropOldest));
  rtm::OutPort<RTM::TimedFloat6> out("out0", "sensor0");
  ASSERT_TRUE(out.connect(*latest));
  ASSERT_TRUE(out.connect(*fifo));
  RTM::TimedFloat6 datum{};
  RTM::TimedFloat6 got{};
  out.write(datum);  // first use of everything outside the measured loop
  latest->read(got);
  fifo->read(got);

  const std::uint64_t before = rtm_test::allocations_total();
  for (int i = 0; i < 1000; ++i) {
    datum.val[0] = static_cast<float>(i);
    out.write(datum);
    out.write(datum);
    fifo->read(got);
    EXPECT_EQ(latest->read(got), rtm::ReadResult::NewData);
    latest->deliver(datum);
  }
  const std::uint64_t during = rtm_test::allocations_total() - before;
  EXPECT_EQ(during, 0u);
  EXPECT_FLOAT_EQ(got.val[0], 999.0f);
  EXPECT_GT(fifo->counters_snapshot().dropped, 0u);  // the full-FIFO path ran too
}

TEST(Allocation, TheCounterSeesAnAllocation) {
  const std::uint64_t before = rtm_test::allocations_total();
  auto* p = new int(4);
  EXPECT_EQ(rtm_test::allocations_total(), before + 1);
  delete p;
}

}  // namespace

namespace {

// A component that reads a stamped datum and writes one, as a chain's middle does; it leaves
// the stamp to its OutPort (derive_stamp_from).
class PassOn final : public rtm::Component {
 public:
  PassOn() : Component("pass0", "test") {}
  void on_cycle(const rtm::CycleContext&) override {
    if (in.read(datum) != rtm::ReadResult::NewData) return;
    datum.tm = {};
    out.write(datum);
  }
  rtm::InPort<RTM::TimedFloat6>& in = add_in_port<RTM::TimedFloat6>("in");
  rtm::OutPort<RTM::TimedFloat6>& out = add_out_port<RTM::TimedFloat6>("out");
  RTM::TimedFloat6 datum{};
};

TEST(Allocation, ACycleWatchedAgainstItsContractEndingAChainAndDerivingAStampAllocatesNothing) {
  auto logic = std::make_unique<PassOn>();
  PassOn& pass = *logic;
  PortableServer::Servant_var<rtm::ComponentServant> servant =
      new rtm::ComponentServant(std::move(logic), rtm::ExternalTick{});
  rtm::TimingContract contract;
  contract.component = "pass0";
  contract.budget_ns = 1;  // every cycle over it: the counting path too
  contract.deadline_ns = 1;
  servant->watch_contract(contract);
  servant->watch_chain({"sample_to_pass", &pass.in, 1, 1});  // late and stale at every cycle
  pass.out.derive_stamp_from({&pass.in});
  servant->on();
  const rtm::CycleFunction cycle = servant->cycle_function();
  RTM::TimedFloat6 datum{};
  datum.tm = rtm::now();
  rtm::CycleContext ctx{0, rtm::monotonic_ns(), rtm::monotonic_ns(), 2'000'000};
  pass.in.deliver(datum);
  ASSERT_TRUE(cycle(ctx));  // first use of everything outside the measured loop

  const std::uint64_t before = rtm_test::allocations_total();
  for (std::uint64_t i = 1; i <= 1000; ++i) {
    pass.in.deliver(datum);
    ctx = {i, rtm::monotonic_ns(), rtm::monotonic_ns(), 2'000'000};
    EXPECT_TRUE(cycle(ctx));
  }
  const std::uint64_t during = rtm_test::allocations_total() - before;
  EXPECT_EQ(during, 0u);
  const RTM::ContractStatus status = servant->contract();
  EXPECT_EQ(status.over_budget, 1001u) << "the watch ran in every cycle";
  EXPECT_EQ(servant->chain_status().at(0).late, 1001u) << "and so did the chain's";
  RTM::TimedFloat6 written{};
  ASSERT_TRUE(pass.out.latest(written));
  EXPECT_EQ(rtm::to_ns(written.tm), rtm::to_ns(datum.tm)) << "and the OutPort's stamp derivation";
  servant->off();
}

}  // namespace
