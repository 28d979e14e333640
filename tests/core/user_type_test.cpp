// SPDX-License-Identifier: Apache-2.0
// A data type of a project's own IDL on ports, written in the order a newcomer writes it: the
// rtm headers first, the stub header after them, then RTM_DATA_TYPE. The ports' templates are
// defined before the stub header declares the type's Any operators; this file compiles only
// because they reach those operators through the traits.
#include "rtm/component.h"
#include "rtm/inport.h"
#include "rtm/orb.h"
#include "rtm/outport.h"

#include "core_test_support.h"

#include "test_types.hh"

RTM_DATA_TYPE(RtmTest, TimedPose);      // its values counted from its type
RTM_DATA_TYPE(RtmTest, TimedMixed, 0);  // given: a sequence, any number

#include <gtest/gtest.h>

namespace {

using rtm::ReadResult;
using rtm::test::eventually;
using rtm::test::float6;
using Pose = RtmTest::TimedPose;

class UserTypeTest : public rtm::test::OrbTest {};

Pose pose(double x) {
  Pose p{};
  p.tm = rtm::now();
  p.p.x = x;
  p.p.y = -x;
  p.p.z = 0.25;
  for (int i = 0; i < 4; ++i) p.q[i] = 0.5 * i;
  return p;
}

rtm::OutPortOptions through_the_orb() {
  rtm::OutPortOptions o;
  o.in_process = false;
  o.shared_memory = false;
  return o;
}

TEST_F(UserTypeTest, AnOutPortOfAUserTypeAnswersGetWithItsLatestDatum) {
  PortableServer::Servant_var<rtm::OutPort<Pose>> out = new rtm::OutPort<Pose>("pose", "tracker0");
  RTM::OutPortEx_var ref = out->activate(orb());
  CORBA::TypeCode_var type = ref->port_type();
  EXPECT_TRUE(type->equivalent(RtmTest::_tc_TimedPose));
  out->write(pose(1.5));
  CORBA::Any_var got = ref->get();
  const Pose* d = nullptr;
  ASSERT_TRUE(got.in() >>= d);
  EXPECT_DOUBLE_EQ(d->p.x, 1.5);
  EXPECT_DOUBLE_EQ(d->q[3], 1.5);
  out->deactivate();
}

TEST_F(UserTypeTest, AnInPortOfAUserTypeTakesItsTypeAndRefusesAnother) {
  PortableServer::Servant_var<rtm::InPort<Pose>> in =
      new rtm::InPort<Pose>("pose", "gripper0", rtm::InPortPolicy::fifo(4));
  RTM::InPortEx_var ref = in->activate(orb());
  CORBA::Any right;
  right <<= pose(2.0);
  ref->put(right);
  CORBA::Any wrong;
  wrong <<= float6(1.0f);
  EXPECT_THROW(ref->put(wrong), CORBA::BAD_PARAM);
  Pose d{};
  ASSERT_EQ(in->read(d), ReadResult::NewData);
  EXPECT_DOUBLE_EQ(d.p.y, -2.0);
  EXPECT_EQ(in->read(d), ReadResult::OldData);
  in->deactivate();
}

TEST_F(UserTypeTest, ASubscriptionThroughTheOrbCarriesEveryDatumOfAUserTypeInOrder) {
  PortableServer::Servant_var<rtm::OutPort<Pose>> out =
      new rtm::OutPort<Pose>("pose", "tracker0", through_the_orb());
  PortableServer::Servant_var<rtm::InPort<Pose>> in =
      new rtm::InPort<Pose>("pose", "gripper0", rtm::InPortPolicy::fifo(8));
  RTM::InPortEx_var in_ref = in->activate(orb());
  ASSERT_TRUE(out->subscribe(RTM::repeated, in_ref.in()));
  for (int i = 1; i <= 3; ++i) out->write(pose(i));
  ASSERT_TRUE(eventually([&] { return in->counters_snapshot().accepted == 3; }));
  for (int i = 1; i <= 3; ++i) {
    Pose d{};
    ASSERT_EQ(in->read(d), ReadResult::NewData);
    EXPECT_DOUBLE_EQ(d.p.x, i);
  }
  out->close();
  in->deactivate();
}

TEST_F(UserTypeTest, AUserTypeWithASequenceTravelsThroughTheOrbWhole) {
  using Mixed = RtmTest::TimedMixed;
  static_assert(!rtm::DataTraits<Mixed>::fixed_size);
  PortableServer::Servant_var<rtm::OutPort<Mixed>> out =
      new rtm::OutPort<Mixed>("mixed", "source0", through_the_orb());
  PortableServer::Servant_var<rtm::InPort<Mixed>> in =
      new rtm::InPort<Mixed>("mixed", "sink0", rtm::InPortPolicy::latest());
  RTM::InPortEx_var in_ref = in->activate(orb());
  ASSERT_TRUE(out->subscribe(RTM::repeated, in_ref.in()));
  Mixed m{};
  m.tm = rtm::now();
  m.n = 42;
  m.on = true;
  m.mode = RtmTest::RUN;
  m.data.length(3);
  for (CORBA::ULong i = 0; i < 3; ++i) m.data[i] = 0.5f * static_cast<float>(i + 1);
  out->write(m);
  ASSERT_TRUE(eventually([&] { return in->counters_snapshot().accepted == 1; }));
  Mixed d{};
  ASSERT_EQ(in->read(d), ReadResult::NewData);
  EXPECT_EQ(d.n, 42);
  EXPECT_EQ(d.mode, RtmTest::RUN);
  ASSERT_EQ(d.data.length(), 3u);
  EXPECT_FLOAT_EQ(d.data[2], 1.5f);
  out->close();
  in->deactivate();
}

TEST(UserTypeValues, AreTheNumericLeavesAfterTheStampAndNoneWhenASequenceMakesTheirNumberFree) {
  EXPECT_EQ(rtm::count_values(RtmTest::_tc_TimedPose), 7u);     // p.x p.y p.z q[0..3]
  EXPECT_EQ(rtm::count_values(RtmTest::_tc_TimedScalars), 8u);  // every basic kind but the string
  EXPECT_EQ(rtm::count_values(RtmTest::_tc_Plain), 2u);         // no stamp: every member counts
  EXPECT_EQ(rtm::count_values(RtmTest::_tc_TimedPath), 0u);     // a sequence of structs
  EXPECT_EQ(rtm::count_values(RTM::_tc_TimedFloat6), 6u);
  EXPECT_EQ(rtm::count_values(CORBA::TypeCode::_nil()), 0u);
}

TEST_F(UserTypeTest, APortOfACountedTypeTakesADescriptionOfEveryValueAndRefusesAShortOne) {
  PortableServer::Servant_var<rtm::OutPort<Pose>> out = new rtm::OutPort<Pose>("pose", "tracker0");
  EXPECT_EQ(out->element_count(), 7u);
  EXPECT_THROW(out->set_info({"a pose", rtm::elements("x y z", "m m m")}), std::invalid_argument);
  EXPECT_NO_THROW(out->set_info({"a pose", rtm::elements("x y z qw qx qy qz", "m m m 1 1 1 1")}));
  PortableServer::Servant_var<rtm::InPort<RtmTest::TimedMixed>> in =
      new rtm::InPort<RtmTest::TimedMixed>("mixed", "sink0", rtm::InPortPolicy::latest());
  EXPECT_EQ(in->element_count(), 0u);
}

}  // namespace
