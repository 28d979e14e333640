// SPDX-License-Identifier: Apache-2.0
#include "rtm_test/allocation_counter.h"

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
