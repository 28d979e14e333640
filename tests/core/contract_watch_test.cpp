// SPDX-License-Identifier: Apache-2.0
// A component watched against its timing contract (ComponentServant::watch_contract,
// rt/cycle_watch.h): the arithmetic on fixed times, then a real activity whose cycle spins past
// its budget (a spin is a lower bound on a cycle's length whatever the machine does).
#include "core_test_support.h"

#include "rt/clock.h"
#include "rt/cycle_watch.h"
#include "rtm/data.h"

#include "test_types.hh"

RTM_DATA_TYPE(RtmTest, Plain);  // no stamp: a chain cannot end on it

#include <gtest/gtest.h>

#include <atomic>
#include <string>

namespace {

using rtm::test::eventually;
using rtm::test::fast;

TEST(CycleWatch, CountsACycleOverItsBudgetAndOneEndingPastItsDeadlineEachOnItsOwn) {
  rtm::CycleWatch watch;
  watch.set_limits({.budget_ns = 100'000, .deadline_ns = 500'000});
  // released at 1 ms, started 0.3 ms late, ran 0.05 ms: within both.
  auto v = watch.record(1'000'000, 1'300'000, 1'350'000);
  EXPECT_FALSE(v.over_budget);
  EXPECT_FALSE(v.missed_deadline);
  // started 0.45 ms late, ran 0.08 ms: within its budget, ended 0.53 ms after release.
  v = watch.record(3'000'000, 3'450'000, 3'530'000);
  EXPECT_FALSE(v.over_budget);
  EXPECT_TRUE(v.missed_deadline);
  // started on time, ran 0.2 ms: over its budget, within its deadline.
  v = watch.record(5'000'000, 5'000'000, 5'200'000);
  EXPECT_TRUE(v.over_budget);
  EXPECT_FALSE(v.missed_deadline);
  // exactly at each limit is kept.
  v = watch.record(7'000'000, 7'400'000, 7'500'000);
  EXPECT_FALSE(v.over_budget);
  EXPECT_FALSE(v.missed_deadline);

  const rtm::CycleWatchStats s = watch.stats();
  EXPECT_EQ(s.cycles, 4u);
  EXPECT_EQ(s.over_budget, 1u);
  EXPECT_EQ(s.missed_deadline, 1u);
  EXPECT_EQ(s.cycle_max_ns, 200'000);
  EXPECT_EQ(s.response_max_ns, 530'000);
  EXPECT_GT(s.cycle_max_at_ns, 0) << "when the longest cycle ran";
  EXPECT_GT(s.response_max_at_ns, 0);
}

TEST(CycleWatch, ALimitOfZeroIsNotWatchedButTheFiguresAreKept) {
  rtm::CycleWatch watch;
  const auto v = watch.record(0, 0, 5'000'000);
  EXPECT_FALSE(v.over_budget);
  EXPECT_FALSE(v.missed_deadline);
  EXPECT_EQ(watch.stats().cycle_max_ns, 5'000'000);
  EXPECT_EQ(watch.stats().over_budget, 0u);
}

// Spins spin_ns in each cycle after the first `quiet` ones.
class Spinner final : public rtm::Component {
 public:
  explicit Spinner(std::int64_t spin_ns) : Component("spinner0", "test"), spin_ns_(spin_ns) {}
  void on_cycle(const rtm::CycleContext&) override {
    const std::int64_t until = rtm::monotonic_ns() + spin_ns_;
    while (rtm::monotonic_ns() < until) {
    }
    cycles.fetch_add(1);
  }
  void on_stop() override { stops.fetch_add(1); }
  std::atomic<int> cycles{0};
  std::atomic<int> stops{0};

 private:
  std::int64_t spin_ns_;
};

double statistic(rtm::ComponentServant& servant, const std::string& name) {
  RTM::StatisticList_var stats = servant.statistics();
  for (CORBA::ULong i = 0; i < stats->length(); ++i)
    if (name == stats[i].name.in()) return stats[i].value;
  return -1;
}

rtm::TimingContract contract(std::int64_t budget_ns, std::int64_t deadline_ns, rtm::MissAction on_miss) {
  rtm::TimingContract c;
  c.component = "spinner0";
  c.period_ns = fast().period_ns;
  c.deadline_ns = deadline_ns;
  c.budget_ns = budget_ns;
  c.on_miss = on_miss;
  return c;
}

class ContractWatch : public rtm::test::OrbTest {};

TEST_F(ContractWatch, EveryCycleSpinningPastItsBudgetIsCountedAndTheStatisticsAndContractSaySo) {
  auto logic = std::make_unique<Spinner>(300'000);
  Spinner& s = *logic;
  rtm::ComponentServant servant(std::move(logic), fast());
  servant.watch_contract(contract(200'000, 250'000, rtm::MissAction::count));
  servant.on();
  ASSERT_TRUE(eventually([&] { return s.cycles.load() >= 5; }));
  servant.off();
  const int cycles = s.cycles.load();
  const RTM::ContractStatus status = servant.contract();
  EXPECT_TRUE(status.watched);
  EXPECT_EQ(status.cycles, static_cast<unsigned long long>(cycles));
  EXPECT_EQ(status.over_budget, static_cast<unsigned long long>(cycles)) << "each spun 300 us against 200 us";
  EXPECT_GE(status.missed_deadline, static_cast<unsigned long long>(cycles)) << "each ended 300 us or more after release";
  EXPECT_GE(status.cycle_max_ns, 300'000u);
  EXPECT_EQ(status.contract.budget_ns, 200'000u);
  EXPECT_EQ(status.contract.deadline_ns, 250'000u);
  EXPECT_EQ(status.contract.on_miss, RTM::MISS_COUNT);
  EXPECT_EQ(statistic(servant, "over_budget"), cycles);
  EXPECT_GE(statistic(servant, "cycle_time_max"), 300.0) << "in us";
  EXPECT_EQ(servant.current_state(), RTM::COMPONENT_OFF) << "count only: it ran on";
}

TEST_F(ContractWatch, BrakeStopsTheComponentAtItsFirstMissAndItsOnStopRuns) {
  auto logic = std::make_unique<Spinner>(300'000);
  Spinner& s = *logic;
  rtm::ComponentServant servant(std::move(logic), fast());
  servant.watch_contract(contract(200'000, 0, rtm::MissAction::brake));
  servant.on();
  ASSERT_TRUE(eventually([&] { return servant.current_state() == RTM::COMPONENT_ERROR; }));
  ASSERT_TRUE(eventually([&] { return s.stops.load() >= 1; })) << "on_stop: an actuator commands zero";
  EXPECT_EQ(s.cycles.load(), 1) << "no cycle after the first miss";
  EXPECT_NE(servant.error_text().find("over its budget of 200 us"), std::string::npos) << servant.error_text();
  servant.off();
}

TEST_F(ContractWatch, AComponentNotWatchedSaysSoAndCountsNothing) {
  auto logic = std::make_unique<Spinner>(300'000);
  Spinner& s = *logic;
  rtm::ComponentServant servant(std::move(logic), fast());
  servant.on();
  ASSERT_TRUE(eventually([&] { return s.cycles.load() >= 3; }));
  servant.off();
  const RTM::ContractStatus status = servant.contract();
  EXPECT_FALSE(status.watched);
  EXPECT_EQ(status.over_budget, 0u);
  EXPECT_EQ(status.contract.period_ns, static_cast<unsigned long long>(fast().period_ns));
  EXPECT_EQ(statistic(servant, "over_budget"), -1) << "no such statistic";
}

// Reads its one InPort each cycle, as the end of a chain does.
class ChainEnd final : public rtm::Component {
 public:
  ChainEnd() : Component("end0", "test") {}
  void on_cycle(const rtm::CycleContext&) override {
    RTM::TimedFloat6 datum{};
    in.read(datum);
    cycles.fetch_add(1);
  }
  rtm::InPort<RTM::TimedFloat6>& in = add_in_port<RTM::TimedFloat6>("in");
  std::atomic<int> cycles{0};
};

// Reads its InPort, and after `acting` cycles without a new datum stops acting on the last one
// (expire_last()), as the actuator does when its watchdog brakes.
class BrakingChainEnd final : public rtm::Component {
 public:
  explicit BrakingChainEnd(int acting) : Component("end0", "test"), acting_(acting) {}
  void on_cycle(const rtm::CycleContext&) override {
    RTM::TimedFloat6 datum{};
    if (in.read(datum) == rtm::ReadResult::NewData) {
      without_ = 0;
    } else if (++without_ == acting_) {
      in.expire_last();
    }
    cycles.fetch_add(1);
  }
  rtm::InPort<RTM::TimedFloat6>& in = add_in_port<RTM::TimedFloat6>("in");
  std::atomic<int> cycles{0};

 private:
  const int acting_;
  int without_ = 0;
};

TEST_F(ContractWatch, AChainsEndMeasuresFromTheStampOfTheSampleItsDataDeriveFrom) {
  auto logic = std::make_unique<ChainEnd>();
  ChainEnd& end = *logic;
  rtm::ComponentServant servant(std::move(logic), fast());
  servant.watch_chain({"sample_to_end", &end.in, 10'000'000, 20'000'000});
  // A datum whose sample is 30 ms old when it is delivered: older than both limits.
  RTM::TimedFloat6 datum{};
  datum.tm = rtm::from_ns(rtm::to_ns(rtm::now()) - 30'000'000);
  end.in.deliver(datum);
  servant.on();
  ASSERT_TRUE(eventually([&] { return end.cycles.load() >= 5; }));
  servant.off();
  EXPECT_GE(statistic(servant, "chain.sample_to_end.latency_max"), 30'000.0) << "us";
  EXPECT_EQ(statistic(servant, "chain.sample_to_end.late"), 1.0) << "one datum, read once, late once";
  EXPECT_EQ(statistic(servant, "chain.sample_to_end.stale"), end.cycles.load())
      << "every cycle acted on the 30 ms old datum the port kept";
  EXPECT_GE(statistic(servant, "chain.sample_to_end.age_max"), 30'000.0);
  EXPECT_EQ(end.in.stamps_taken(), 1u);
}

TEST_F(ContractWatch, CyclesThatNoLongerActOnTheLastDatumCountNoAgeAndNoStaleCycle) {
  auto logic = std::make_unique<BrakingChainEnd>(2);
  BrakingChainEnd& end = *logic;
  rtm::ComponentServant servant(std::move(logic), fast());
  servant.watch_chain({"sample_to_end", &end.in, 0, 20'000'000});
  RTM::TimedFloat6 datum{};
  datum.tm = rtm::from_ns(rtm::to_ns(rtm::now()) - 30'000'000);
  end.in.deliver(datum);
  servant.on();
  ASSERT_TRUE(eventually([&] { return end.cycles.load() >= 8; }));
  EXPECT_EQ(statistic(servant, "chain.sample_to_end.stale"), 2.0)
      << "the cycle reading it and the one repeating it; then it expired";
  // A new datum is acted on again: its cycles count once more.
  datum.tm = rtm::from_ns(rtm::to_ns(rtm::now()) - 30'000'000);
  end.in.deliver(datum);
  ASSERT_TRUE(eventually([&] { return statistic(servant, "chain.sample_to_end.stale") >= 3.0; }));
  const int after = end.cycles.load();
  ASSERT_TRUE(eventually([&] { return end.cycles.load() >= after + 4; }));
  servant.off();
  EXPECT_EQ(end.in.stamps_taken(), 2u);
  EXPECT_EQ(statistic(servant, "chain.sample_to_end.stale"), 4.0);
  EXPECT_GE(statistic(servant, "chain.sample_to_end.age_max"), 30'000.0);
}

TEST_F(ContractWatch, AChainThatSaysBrakeStopsItsEndAtTheFirstLateDatumAndSaysWhich) {
  auto logic = std::make_unique<ChainEnd>();
  ChainEnd& end = *logic;
  rtm::ComponentServant servant(std::move(logic), fast());
  servant.watch_chain({"sample_to_end", &end.in, 10'000'000, 0, rtm::MissAction::brake});
  RTM::TimedFloat6 datum{};
  datum.tm = rtm::from_ns(rtm::to_ns(rtm::now()) - 30'000'000);
  end.in.deliver(datum);
  servant.on();
  ASSERT_TRUE(eventually([&] { return servant.current_state() == RTM::COMPONENT_ERROR; }));
  EXPECT_EQ(end.cycles.load(), 1) << "the first cycle read it, and was the last";
  EXPECT_NE(servant.error_text().find("chain sample_to_end's data"), std::string::npos) << servant.error_text();
  EXPECT_NE(servant.error_text().find("past its deadline of 10 ms"), std::string::npos) << servant.error_text();
  const auto chains = servant.chain_status();
  ASSERT_EQ(chains.size(), 1u);
  EXPECT_EQ(chains[0].late, 1u);
  servant.off();
}

TEST_F(ContractWatch, AChainWatchIsRefusedOnAPortWhoseDatumCarriesNoStampAndTwiceUnderOneName) {
  class Plain final : public rtm::Component {
   public:
    Plain() : Component("plain0", "test") {}
    void on_cycle(const rtm::CycleContext&) override {}
    rtm::InPort<RTM::TimedFloat6>& stamped = add_in_port<RTM::TimedFloat6>("stamped");
    rtm::InPort<RtmTest::Plain>& plain = add_in_port<RtmTest::Plain>("plain");
  };
  auto logic = std::make_unique<Plain>();
  Plain& p = *logic;
  rtm::ComponentServant servant(std::move(logic), fast());
  EXPECT_THROW(servant.watch_chain({"c", &p.plain, 0, 0}), std::invalid_argument);
  servant.watch_chain({"c", &p.stamped, 0, 0});
  EXPECT_THROW(servant.watch_chain({"c", &p.stamped, 0, 0}), std::invalid_argument);
}

}  // namespace
