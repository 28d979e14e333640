// SPDX-License-Identifier: Apache-2.0
// An OutPort whose data derive their stamp from InPorts (OutPortBase::derive_stamp_from): the
// core passes the stamp of the sample a datum derives from on, so a chain's end sees its age
// whether or not the component in between copies tm. Stamps are set by the test, so every
// expected stamp is exact.
#include "core_test_support.h"

#include "rtm/data.h"
#include "rtm/inport.h"
#include "rtm/outport.h"

#include "test_types.hh"

RTM_DATA_TYPE(RtmTest, Plain);  // no stamp

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

namespace {

RTM::TimedFloat6 stamped_at(std::int64_t ns, float value = 0) {
  RTM::TimedFloat6 d{};
  d.tm = rtm::from_ns(ns);
  d.val[0] = value;
  return d;
}

// A component's ports as its cycle uses them: two inputs, one output derived from both, and
// the InPort the output feeds in this process (what the next component reads).
// Servants, reference counted: made with new.
using In6 = rtm::InPort<RTM::TimedFloat6>;
using Out6 = rtm::OutPort<RTM::TimedFloat6>;
struct Ports {
  PortableServer::Servant_var<In6> a_ = new In6("a", "mid0"), b_ = new In6("b", "mid0"), next_ = new In6("in", "end0");
  PortableServer::Servant_var<Out6> out_ = new Out6("out", "mid0");
  In6 &a = *a_, &b = *b_, &next = *next_;
  Out6& out = *out_;
  Ports() { EXPECT_TRUE(out.connect(next)); }
  void give(rtm::InPort<RTM::TimedFloat6>& port, std::int64_t stamp_ns) {
    port.deliver(stamped_at(stamp_ns));
    RTM::TimedFloat6 got{};
    ASSERT_EQ(port.read(got), rtm::ReadResult::NewData);
  }
  // Writes a datum stamped own_ns; returns the stamp the next component reads.
  std::int64_t write(std::int64_t own_ns) {
    out.write(stamped_at(own_ns, 1));
    RTM::TimedFloat6 got{};
    EXPECT_EQ(next.read(got), rtm::ReadResult::NewData);
    EXPECT_EQ(got.val[0], 1.0f) << "the datum itself is the one written";
    return rtm::to_ns(got.tm);
  }
};

class StampDerivation : public rtm::test::OrbTest {};

constexpr std::int64_t kSecond = 1'000'000'000;
constexpr std::int64_t kT = 1'700'000'000 * kSecond;  // a fixed wall-clock time

TEST_F(StampDerivation, ADerivedDatumCarriesTheOlderOfTheStampsItsInputsGave) {
  Ports p;
  p.out.derive_stamp_from({&p.a, &p.b});
  EXPECT_EQ(p.out.stamp_sources_text(), "a+b");
  EXPECT_EQ(p.write(kT + 9), kT + 9) << "no input has given a datum yet: the datum keeps its own stamp";
  p.give(p.a, kT + 1);
  EXPECT_EQ(p.write(kT + 9), kT + 1) << "a's sample";
  p.give(p.b, kT + 2);
  EXPECT_EQ(p.write(kT + 9), kT + 1) << "a's is the older";
  p.give(p.a, kT + 3);
  EXPECT_EQ(p.write(kT + 9), kT + 2) << "now b's is";
  p.out.derive_stamp_from({});
  EXPECT_EQ(p.write(kT + 9), kT + 9) << "no derivation: the component's own stamp";
}

TEST_F(StampDerivation, AnInputStampedZeroCountsAsNone) {
  Ports p;
  p.out.derive_stamp_from({&p.a, &p.b});
  p.give(p.a, 0);  // e.g. a reference nobody stamps
  EXPECT_EQ(p.write(kT + 9), kT + 9);
  p.give(p.b, kT + 4);
  EXPECT_EQ(p.write(kT + 9), kT + 4);
}

TEST_F(StampDerivation, APortOrAnInputWithoutAStampIsRefusedAndSoIsNoPortOrTooMany) {
  Ports p;
  PortableServer::Servant_var<rtm::OutPort<RtmTest::Plain>> plain_out_ = new rtm::OutPort<RtmTest::Plain>("plain_out", "mid0");
  PortableServer::Servant_var<rtm::InPort<RtmTest::Plain>> plain_in_ = new rtm::InPort<RtmTest::Plain>("plain_in", "mid0");
  auto& plain_out = *plain_out_;
  auto& plain_in = *plain_in_;
  EXPECT_FALSE(plain_out.stamped());
  EXPECT_TRUE(p.out.stamped());
  EXPECT_THROW(plain_out.derive_stamp_from({&p.a}), std::invalid_argument);
  EXPECT_NO_THROW(plain_out.derive_stamp_from({})) << "ending no derivation is no error";
  try {
    p.out.derive_stamp_from({&p.a, &plain_in});
    FAIL() << "an unstamped input was taken";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("plain_in"), std::string::npos) << e.what();
  }
  EXPECT_THROW(p.out.derive_stamp_from({nullptr}), std::invalid_argument);
  std::vector<const rtm::InPortBase*> many(rtm::OutPortBase::kMaxStampSources + 1, &p.a);
  EXPECT_THROW(p.out.derive_stamp_from(many), std::invalid_argument);
  // A refused declaration leaves none behind.
  EXPECT_EQ(p.out.stamp_sources_text(), "");
  p.give(p.a, kT + 1);
  EXPECT_EQ(p.write(kT + 9), kT + 9);
}

}  // namespace
