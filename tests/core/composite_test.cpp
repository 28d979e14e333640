// SPDX-License-Identifier: Apache-2.0
// The host's composites on diagrams that are not the servo: a ticked chain of five members and
// a stage runs in the diagram's order, a datum crossing the whole chain within one cycle; the
// members must be the diagram's; and a composite's holds on its members, renewed and released
// through a real ORB.
#include "core_test_support.h"
#include "host/lease.h"
#include "host/ticked_composite.h"
#include "rtm/data.h"
#include "rtm/diagram.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <mutex>
#include <string>
#include <vector>

namespace {

using rtm::test::eventually;

// Written on the tick's thread only; read after the tick has stopped.
struct TickLog {
  std::vector<std::string> events;
};

// Writes 1, 2, 3, ... one a cycle.
class Source final : public rtm::Component {
 public:
  Source(std::string name, TickLog& log)
      : Component(std::move(name), "source"), log_(log), out_(add_out_port<RTM::TimedFloat6>("out")) {}
  void on_cycle(const rtm::CycleContext&) override {
    log_.events.push_back(name());
    RTM::TimedFloat6 d{};
    d.val[0] = static_cast<float>(++n_);
    out_.write(d);
  }

 private:
  TickLog& log_;
  rtm::OutPort<RTM::TimedFloat6>& out_;
  long n_ = 0;
};

// Doubles what arrived this cycle.
class Twice final : public rtm::Component {
 public:
  Twice(std::string name, TickLog& log)
      : Component(std::move(name), "filter"),
        log_(log),
        in_(add_in_port<RTM::TimedFloat6>("in")),
        out_(add_out_port<RTM::TimedFloat6>("out")) {}
  void on_cycle(const rtm::CycleContext&) override {
    log_.events.push_back(name());
    RTM::TimedFloat6 d{};
    if (in_.read(d) != rtm::ReadResult::NewData) return;
    d.val[0] *= 2;
    out_.write(d);
  }

 private:
  TickLog& log_;
  rtm::InPort<RTM::TimedFloat6>& in_;
  rtm::OutPort<RTM::TimedFloat6>& out_;
};

// Keeps what arrived each cycle (0 when nothing did).
class Sink final : public rtm::Component {
 public:
  Sink(std::string name, TickLog& log)
      : Component(std::move(name), "sink"), log_(log), in_(add_in_port<RTM::TimedFloat6>("in")) {}
  void on_cycle(const rtm::CycleContext&) override {
    log_.events.push_back(name());
    RTM::TimedFloat6 d{};
    got.push_back(in_.read(d) == rtm::ReadResult::NewData ? d.val[0] : 0.0f);
    cycles.fetch_add(1);
  }
  std::vector<float> got;
  std::atomic<int> cycles{0};

 private:
  TickLog& log_;
  rtm::InPort<RTM::TimedFloat6>& in_;
};

struct LoggingStage final : rtm::TickStage {
  explicit LoggingStage(TickLog& log) : log_(log) {}
  std::int64_t take_over() override {
    take_overs.fetch_add(1);
    return 0;
  }
  void hand_back(std::int64_t) override { hand_backs.fetch_add(1); }
  bool receive(std::int64_t) override {
    log_.events.push_back("receive");
    return true;
  }
  bool transmit(std::int64_t) override {
    log_.events.push_back("transmit");
    return true;
  }
  std::atomic<int> take_overs{0}, hand_backs{0};

 private:
  TickLog& log_;
};

rtm::Diagram chain() {
  return {.name = "chain",
          .members = {{"src"}, {"x2a"}, {"x2b"}, {"x2c"}, {"sink"}},
          .ticked = true,
          .connections = {{{"src", "out"}, {"x2a", "in"}},
                          {{"x2a", "out"}, {"x2b", "in"}},
                          {{"x2b", "out"}, {"x2c", "in"}},
                          {{"x2c", "out"}, {"sink", "in"}}}};
}

// The chain's members, handed over in an order that is not the diagram's.
std::vector<std::unique_ptr<rtm::Component>> chain_members(TickLog& log, Sink** sink) {
  std::vector<std::unique_ptr<rtm::Component>> members;
  auto s = std::make_unique<Sink>("sink", log);
  *sink = s.get();
  members.push_back(std::move(s));
  members.push_back(std::make_unique<Twice>("x2c", log));
  members.push_back(std::make_unique<Twice>("x2a", log));
  members.push_back(std::make_unique<Source>("src", log));
  members.push_back(std::make_unique<Twice>("x2b", log));
  return members;
}

using rtm::test::fast;

TEST(TickedComposite, RunsAnyDeclaredChainInTheDiagramsOrderBetweenTheStagesHalves) {
  TickLog log;
  LoggingStage stage(log);
  Sink* sink = nullptr;
  rtm::TickedComposite composite("chain0", "chain", chain(), chain_members(log, &sink), fast(), {}, &stage);
  ASSERT_TRUE(composite.runs_stage());
  composite.on_start();
  ASSERT_TRUE(eventually([&] { return sink->cycles.load() >= 10; }));
  composite.on_stop();

  EXPECT_EQ(stage.take_overs.load(), 1);
  EXPECT_EQ(stage.hand_backs.load(), 1);
  const std::vector<std::string> cycle{"receive", "src", "x2a", "x2b", "x2c", "sink", "transmit"};
  ASSERT_EQ(log.events.size() % cycle.size(), 0u);
  for (std::size_t i = 0; i < log.events.size(); ++i)
    ASSERT_EQ(log.events[i], cycle[i % cycle.size()]) << "event " << i;
  // The source's n-th datum, doubled three times, reached the sink in the cycle it was written.
  for (std::size_t n = 0; n < sink->got.size(); ++n) EXPECT_EQ(sink->got[n], 8.0f * (n + 1)) << "cycle " << n;
}

TEST(TickedComposite, OffRemovesTheConnectionsAndOnMakesThemAgain) {
  TickLog log;
  Sink* sink = nullptr;
  rtm::TickedComposite composite("chain1", "chain", chain(), chain_members(log, &sink), fast());
  EXPECT_FALSE(composite.runs_stage());
  composite.on_start();
  ASSERT_TRUE(eventually([&] { return sink->cycles.load() >= 3; }));
  composite.on_stop();
  const std::size_t before = sink->got.size();
  composite.on_start();
  ASSERT_TRUE(eventually([&] { return sink->cycles.load() >= static_cast<int>(before) + 3; }));
  composite.on_stop();
  ASSERT_GT(sink->got.size(), before);
  EXPECT_GT(sink->got.back(), 0.0f) << "the chain was connected again, once";
  for (auto* member : composite.members()) EXPECT_EQ(member->current_state(), RTM::COMPONENT_OFF);
}

TEST(TickedComposite, SaysItsMembersInTheDiagramsOrderThroughItsServantAndAPlainComponentNone) {
  TickLog log;
  Sink* sink = nullptr;
  PortableServer::Servant_var<rtm::ComponentServant> servant = new rtm::ComponentServant(
      std::make_unique<rtm::TickedComposite>("chain2", "chain", chain(), chain_members(log, &sink), fast()),
      rtm::ExternalTick{});
  RTM::NameList_var names = servant->members();
  ASSERT_EQ(names->length(), 5u);
  const std::vector<std::string> expected{"src", "x2a", "x2b", "x2c", "sink"};  // handed over in another order
  for (CORBA::ULong i = 0; i < names->length(); ++i) EXPECT_EQ(std::string(names[i].in()), expected[i]);
  PortableServer::Servant_var<rtm::ComponentServant> plain =
      new rtm::ComponentServant(std::make_unique<Sink>("alone", log), rtm::ExternalTick{});
  RTM::NameList_var none = plain->members();
  EXPECT_EQ(none->length(), 0u);
}

TEST(TickedComposite, MembersMustBeTheDiagramsAndTheDiagramTicked) {
  TickLog log;
  Sink* sink = nullptr;
  auto members = chain_members(log, &sink);
  members.push_back(std::make_unique<Twice>("stray", log));
  try {
    rtm::TickedComposite("c", "chain", chain(), std::move(members), fast());
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "c: member stray is not in the diagram");
  }
  members = chain_members(log, &sink);
  members.pop_back();  // x2b
  try {
    rtm::TickedComposite("c", "chain", chain(), std::move(members), fast());
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "c: diagram member x2b was not given");
  }
  auto untimed = chain();
  untimed.ticked = false;
  EXPECT_THROW(rtm::TickedComposite("c", "chain", untimed, chain_members(log, &sink), fast()), std::invalid_argument);
}

TEST(TickedComposite, AConnectionAgainstTheOrderIsRefusedBeforeAnythingRuns) {
  TickLog log;
  Sink* sink = nullptr;
  auto backwards = chain();
  std::swap(backwards.members[1], backwards.members[2]);  // x2b before x2a, which feeds it
  try {
    rtm::TickedComposite("c", "chain", backwards, chain_members(log, &sink), fast());
    FAIL() << "no exception";
  } catch (const rtm::DiagramError& e) {
    EXPECT_NE(std::string(e.what()).find("x2a.out -> x2b.in"), std::string::npos) << e.what();
  }
}

// ---- a chain's stamps across the members ---------------------------------------------------

// Writes a datum whose sample is 50 ms old, a new stamp each cycle; keeps the last it wrote.
class OldSampleSource final : public rtm::Component {
 public:
  OldSampleSource() : Component("src", "source") {}
  void on_cycle(const rtm::CycleContext&) override {
    RTM::TimedFloat6 d{};
    const std::int64_t stamp = rtm::to_ns(rtm::now()) - 50'000'000;
    d.tm = rtm::from_ns(stamp);
    out_.write(d);
    last_stamp_ns.store(stamp);
  }
  std::atomic<std::int64_t> last_stamp_ns{0};

 private:
  rtm::OutPort<RTM::TimedFloat6>& out_ = add_out_port<RTM::TimedFloat6>("out");
};

// Writes what it read stamped now: a component that does not pass the stamp on itself.
class Restamp final : public rtm::Component {
 public:
  explicit Restamp(std::string name) : Component(std::move(name), "filter") {}
  void on_cycle(const rtm::CycleContext&) override {
    RTM::TimedFloat6 d{};
    if (in_.read(d) != rtm::ReadResult::NewData) return;
    d.tm = rtm::now();
    out_.write(d);
  }

 private:
  rtm::InPort<RTM::TimedFloat6>& in_ = add_in_port<RTM::TimedFloat6>("in");
  rtm::OutPort<RTM::TimedFloat6>& out_ = add_out_port<RTM::TimedFloat6>("out");
};

class ChainEnd final : public rtm::Component {
 public:
  ChainEnd() : Component("end", "sink") {}
  void on_cycle(const rtm::CycleContext&) override {
    RTM::TimedFloat6 d{};
    in.read(d);
    cycles.fetch_add(1);
  }
  rtm::InPort<RTM::TimedFloat6>& in = add_in_port<RTM::TimedFloat6>("in");
  std::atomic<int> cycles{0};
};

double statistic(rtm::ComponentServant& servant, const std::string& name) {
  RTM::StatisticList_var stats = servant.statistics();
  for (CORBA::ULong i = 0; i < stats->length(); ++i)
    if (name == stats[i].name.in()) return stats[i].value;
  return -1;
}

TEST(TickedComposite, AChainsEndSeesTheSourcesStampThroughMembersWhosePortsDeriveIt) {
  const rtm::Diagram diagram{.name = "stamps",
                             .members = {{"src"}, {"mid_a"}, {"mid_b"}, {"end"}},
                             .ticked = true,
                             .connections = {{{"src", "out"}, {"mid_a", "in"}},
                                             {{"mid_a", "out"}, {"mid_b", "in"}},
                                             {{"mid_b", "out"}, {"end", "in"}}}};
  std::vector<std::unique_ptr<rtm::Component>> members;
  auto source = std::make_unique<OldSampleSource>();
  auto end = std::make_unique<ChainEnd>();
  OldSampleSource& src = *source;
  ChainEnd& sink = *end;
  members.push_back(std::move(source));
  members.push_back(std::make_unique<Restamp>("mid_a"));
  members.push_back(std::make_unique<Restamp>("mid_b"));
  members.push_back(std::move(end));
  rtm::TickedComposite composite("stamps0", "chain", diagram, std::move(members), fast());
  for (const char* mid : {"mid_a", "mid_b"}) {
    const rtm::Component& c = composite.member(mid).component();
    rtm::out_port_of(c, "out")->derive_stamp_from({rtm::in_port_of(c, "in")});
  }
  rtm::ComponentServant& end_servant = composite.member("end");
  end_servant.watch_chain({"src_to_end", &sink.in, 0, 0});
  composite.on_start();
  ASSERT_TRUE(eventually([&] { return sink.cycles.load() >= 10; }));
  composite.on_stop();

  // The source, both members and the end ran in one cycle of the tick: the end's last datum
  // derives from the source's last sample, whose stamp it carries exactly.
  EXPECT_EQ(sink.in.last_stamp_ns(), src.last_stamp_ns.load());
  EXPECT_GE(statistic(end_servant, "chain.src_to_end.age_max"), 50'000.0) << "us: the sample was 50 ms old";
  EXPECT_GE(statistic(end_servant, "chain.src_to_end.latency_p50"), 50'000.0);
}

// ---- holds --------------------------------------------------------------------------------

// The member's side as a protocol-level peer: records each hold and release it is sent.
class RecordingKeeper final : public rtm::HoldKeeper {
 public:
  struct Call {
    std::string what, holder;
    std::uint32_t lease_ms;
  };
  explicit RecordingKeeper(std::vector<Call>& calls, std::mutex& mutex) : calls_(calls), mutex_(mutex) {}
  void hold(const std::string& holder, std::uint32_t lease_ms) override {
    std::lock_guard lock(mutex_);
    calls_.push_back({"hold", holder, lease_ms});
  }
  void release(const std::string& holder) override {
    std::lock_guard lock(mutex_);
    calls_.push_back({"release", holder, 0});
  }

 private:
  std::vector<Call>& calls_;
  std::mutex& mutex_;
};

class HoldsTest : public rtm::test::OrbTest {};

TEST_F(HoldsTest, ARenewalHoldsEachMemberWithinItsLeaseAndReleasesAtTheEnd) {
  std::vector<RecordingKeeper::Call> calls;
  std::mutex mutex;
  rtm::ComponentServant member(std::make_unique<rtm::test::Doubler>("held0"), fast());
  member.keep_holds(std::make_unique<RecordingKeeper>(calls, mutex));
  RTM::RtComponentEx_var ref = member.activate(orb());
  {
    rtm::HoldRenewal renewal("composite0", {RTM::RtComponentEx::_duplicate(ref.in())}, 100);
    ASSERT_TRUE(eventually([&] { return renewal.rounds() >= 3; }));
  }
  std::lock_guard lock(mutex);
  ASSERT_GE(calls.size(), 4u);
  for (std::size_t i = 0; i + 1 < calls.size(); ++i) {
    EXPECT_EQ(calls[i].what, "hold");
    EXPECT_EQ(calls[i].holder, "composite0");
    EXPECT_EQ(calls[i].lease_ms, 100u);
  }
  EXPECT_EQ(calls.back().what, "release");
  EXPECT_EQ(calls.back().holder, "composite0");
  member.deactivate();
}

TEST_F(HoldsTest, AHoldNotRenewedEndsAndOneRenewedDoesNot) {
  std::mutex mutex;
  std::vector<std::string> expired;
  rtm::ComponentServant member(std::make_unique<rtm::test::Doubler>("held1"), fast());
  member.keep_holds(std::make_unique<rtm::Leases>([&](const std::string& holder, std::uint32_t) {
    std::lock_guard lock(mutex);
    expired.push_back(holder);
  }));
  RTM::RtComponentEx_var ref = member.activate(orb());
  ref->hold("once", 50);  // never renewed
  {
    rtm::HoldRenewal renewal("renewing", {RTM::RtComponentEx::_duplicate(ref.in())}, 200);
    // Once "once" has ended, the renewal has gone on for 2.5 of its leases of 200 ms.
    ASSERT_TRUE(eventually([&] {
      std::lock_guard lock(mutex);
      return !expired.empty() && renewal.rounds() >= 13;
    }));
  }
  std::lock_guard lock(mutex);
  EXPECT_EQ(expired, std::vector<std::string>{"once"}) << "the renewed hold ended";
  member.deactivate();
}

TEST(HoldRenewal, ALeaseOutsideTheKeepersRangeIsRefused) {
  EXPECT_THROW(rtm::HoldRenewal("c", {}, 10), std::invalid_argument);
  EXPECT_THROW(rtm::HoldRenewal("c", {}, 60'001), std::invalid_argument);
}

}  // namespace
