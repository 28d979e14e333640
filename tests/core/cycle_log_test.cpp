// SPDX-License-Identifier: Apache-2.0
// The cycle log under a real activity (its own thread, the log's writer thread, a feeder thread
// delivering meanwhile: the TSan preset runs it), then replayed: every output identical. A FIFO
// read by read_many and a sequence type, whose copy allocates, go through the same taps.
#include "core_test_support.h"

#include "RTMData.hh"
#include "host/cycle_log.h"
#include "rtm_test/temp_dir.h"

#include <gtest/gtest.h>

#include <atomic>
#include <thread>

namespace {

using rtm::ReadResult;
using rtm::test::Doubler;
using rtm::test::eventually;
using rtm::test::fast;
using rtm::test::float6;

class CycleLogTest : public rtm::test::OrbTest {
 protected:
  rtm_test::TempDir dir_{"rtm-cycle-log"};
};

// Runs servant's activity with its cycles logged into `log` while `feed` is called from another
// thread, until the component has run `cycles` cycles.
template <class Feed>
void run_logged(rtm::ComponentServant& servant, const std::string& log, const std::atomic<long>& ran, long cycles,
                Feed feed) {
  rtm::CycleLog cycle_log(servant, log);
  std::atomic<bool> stop{false};
  servant.on();
  std::thread feeder([&] {
    for (int k = 0; !stop.load(); ++k) {
      feed(k);
      std::this_thread::sleep_for(std::chrono::microseconds(300));
    }
  });
  const bool enough = eventually([&] { return ran.load() >= cycles; });
  stop = true;
  feeder.join();
  servant.off();
  EXPECT_TRUE(enough) << "the activity ran " << ran.load() << " cycles";
  EXPECT_EQ(cycle_log.lost(), 0u);
}

TEST_F(CycleLogTest, AFifoReaderUnderItsActivityReplaysIdentically) {
  rtm::ComponentServant servant(std::make_unique<Doubler>("doubler0", rtm::InPortPolicy::fifo(64)), fast());
  auto& d = static_cast<Doubler&>(servant.component());
  const std::string log = dir_.file("doubler.mcap");
  run_logged(servant, log, d.cycles, 200, [&](int k) { d.in.deliver(float6(static_cast<float>(k))); });
  const auto written = d.out.counters_snapshot().written;
  ASSERT_GT(written, 100u);

  const rtm::ReplayResult r =
      rtm::replay_cycle_log(std::make_unique<Doubler>("doubler0", rtm::InPortPolicy::fifo(64)), log);
  EXPECT_GE(r.cycles, 200u);
  EXPECT_EQ(r.writes, written);
  EXPECT_EQ(r.differing, 0u);
  EXPECT_EQ(r.unanswered_reads, 0u);
  EXPECT_EQ(r.unused_answers, 0u);
}

// Reads its FIFO with read_many, 4 at a time, and writes their sum as a sequence.
class Summer final : public rtm::Component {
 public:
  Summer() : Component("summer0", "summer") {}
  void on_cycle(const rtm::CycleContext& ctx) override {
    std::array<RTM::TimedFloat6, 4> batch{};
    std::size_t n = 0;
    while ((n = in.read_many(batch)) > 0) {
      RTM::TimedDoubleSeq out_datum;
      out_datum.tm = batch[0].tm;
      out_datum.data.length(static_cast<CORBA::ULong>(n + 1));
      double sum = 0;
      for (std::size_t i = 0; i < n; ++i) sum += batch[i].val[0];
      for (std::size_t i = 0; i < n; ++i) out_datum.data[static_cast<CORBA::ULong>(i)] = batch[i].val[0];
      out_datum.data[static_cast<CORBA::ULong>(n)] = sum + static_cast<double>(ctx.cycle % 3);
      out.write(out_datum);
    }
    cycles.fetch_add(1);
  }
  rtm::InPort<RTM::TimedFloat6>& in = add_in_port<RTM::TimedFloat6>("in0", rtm::InPortPolicy::fifo(64));
  rtm::OutPort<RTM::TimedDoubleSeq>& out = add_out_port<RTM::TimedDoubleSeq>("sums");
  std::atomic<long> cycles{0};
};

TEST_F(CycleLogTest, ReadManyAndASequenceTypeReplayIdenticallyAndAnotherLawDiffers) {
  rtm::ComponentServant servant(std::make_unique<Summer>(), fast());
  auto& s = static_cast<Summer&>(servant.component());
  const std::string log = dir_.file("summer.mcap");
  run_logged(servant, log, s.cycles, 200, [&](int k) {
    for (int i = 0; i < 3; ++i) s.in.deliver(float6(static_cast<float>(k * 3 + i)));
  });
  const auto written = s.out.counters_snapshot().written;
  ASSERT_GT(written, 100u);

  const rtm::ReplayResult same = rtm::replay_cycle_log(std::make_unique<Summer>(), log);
  EXPECT_EQ(same.writes, written);
  EXPECT_EQ(same.differing, 0u);
  EXPECT_EQ(same.unanswered_reads, 0u);
  EXPECT_EQ(same.unused_answers, 0u);

  // The same ports, another law: its reads are the logged ones, its outputs differ.
  class Differ final : public rtm::Component {
   public:
    Differ() : Component("summer0", "summer") {}
    void on_cycle(const rtm::CycleContext&) override {
      std::array<RTM::TimedFloat6, 4> batch{};
      while (in.read_many(batch) > 0) {
        RTM::TimedDoubleSeq d;
        d.data.length(1);
        d.data[0] = -1;
        out.write(d);
      }
    }
    rtm::InPort<RTM::TimedFloat6>& in = add_in_port<RTM::TimedFloat6>("in0", rtm::InPortPolicy::fifo(64));
    rtm::OutPort<RTM::TimedDoubleSeq>& out = add_out_port<RTM::TimedDoubleSeq>("sums");
  };
  const rtm::ReplayResult other = rtm::replay_cycle_log(std::make_unique<Differ>(), log);
  EXPECT_EQ(other.writes, written);
  EXPECT_EQ(other.differing, written);
  EXPECT_EQ(other.unanswered_reads, 0u);
}

TEST_F(CycleLogTest, APortOfAnotherTypeOrNameIsRefusedBeforeAnyCycle) {
  rtm::ComponentServant servant(std::make_unique<Doubler>(), fast());
  auto& d = static_cast<Doubler&>(servant.component());
  const std::string log = dir_.file("doubler.mcap");
  run_logged(servant, log, d.cycles, 20, [&](int k) { d.in.deliver(float6(static_cast<float>(k))); });
  class OtherType final : public rtm::Component {
   public:
    OtherType() : Component("doubler0", "controller") {}
    void on_cycle(const rtm::CycleContext&) override {}
    rtm::InPort<RTM::TimedFloat3>& in = add_in_port<RTM::TimedFloat3>("in0");
    rtm::OutPort<RTM::TimedFloat6>& out = add_out_port<RTM::TimedFloat6>("out0");
  };
  try {
    rtm::replay_cycle_log(std::make_unique<OtherType>(), log);
    ADD_FAILURE() << "a port of another type was taken";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("doubler0.in0 carries RTM::TimedFloat3 here, RTM::TimedFloat6 in the log"),
              std::string::npos)
        << e.what();
  }
  class OtherName final : public rtm::Component {
   public:
    OtherName() : Component("doubler0", "controller") {}
    void on_cycle(const rtm::CycleContext&) override {}
    rtm::InPort<RTM::TimedFloat6>& in = add_in_port<RTM::TimedFloat6>("input");
    rtm::OutPort<RTM::TimedFloat6>& out = add_out_port<RTM::TimedFloat6>("out0");
  };
  EXPECT_THROW(rtm::replay_cycle_log(std::make_unique<OtherName>(), log), std::runtime_error);
}

}  // namespace
