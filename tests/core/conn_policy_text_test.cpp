// SPDX-License-Identifier: Apache-2.0
// A connection policy's text form (what `rtm connect --policy` and system files take) and its
// IDL form (what a peer sends): every field read back, every bad token named.
#include "rtm/conn_policy.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

namespace {

using rtm::ConnPolicy;
using rtm::ReaderPolicy;

std::string parse_error(const std::string& text) {
  try {
    rtm::parse_conn_policy(text);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(ConnPolicyText, EveryFieldReadsBackFromItsTextInAnyOrderAndSeparator) {
  const ConnPolicy p = rtm::parse_conn_policy("call=250ms,delivery=thread  once reader=fifo:16 path=corba depth=32");
  EXPECT_TRUE(p.once);
  EXPECT_EQ(p.reader, (ReaderPolicy{ReaderPolicy::Kind::fifo, 16}));
  EXPECT_EQ(p.depth, 32u);
  EXPECT_EQ(p.delivery, ConnPolicy::Delivery::thread);
  EXPECT_EQ(p.call_timeout_ms, 250u);
  EXPECT_TRUE(p.corba_only);
  EXPECT_EQ(rtm::to_string(p), "once reader=fifo:16 depth=32 delivery=thread call=250ms path=corba");
  EXPECT_EQ(rtm::parse_conn_policy(rtm::to_string(p)), p);
  EXPECT_EQ(rtm::parse_conn_policy(""), ConnPolicy::repeated());
  EXPECT_EQ(rtm::to_string(ConnPolicy::repeated()), "repeated");
  EXPECT_EQ(rtm::parse_conn_policy("reader=latest delivery=writer path=auto").reader.kind, ReaderPolicy::Kind::latest);
}

TEST(ConnPolicyText, AWrongTokenIsNamedWithWhatItMayBe) {
  EXPECT_NE(parse_error("depth=lots").find("'depth=lots': a whole number from 0 to 4096"), std::string::npos);
  EXPECT_NE(parse_error("depth=4097").find("'depth=4097'"), std::string::npos);
  EXPECT_NE(parse_error("depth=-1").find("'depth=-1'"), std::string::npos);
  EXPECT_NE(parse_error("buffer=4").find("'buffer=4': unknown key"), std::string::npos);
  EXPECT_NE(parse_error("fast").find("'fast': not a policy"), std::string::npos);
  EXPECT_NE(parse_error("call=20").find("written in ms"), std::string::npos);
  EXPECT_NE(parse_error("reader=fifo:0").find("at least 1"), std::string::npos);
  EXPECT_NE(parse_error("reader=ring").find("latest, fifo, fifo:<capacity> or callback"), std::string::npos);
  EXPECT_NE(parse_error("delivery=now").find("writer or thread"), std::string::npos);
  EXPECT_NE(parse_error("once repeated").find("given twice"), std::string::npos);
  EXPECT_NE(parse_error("depth=2 depth=3").find("'depth=3': given twice"), std::string::npos);
  EXPECT_NE(parse_error("once=1").find("take no value"), std::string::npos);
}

TEST(ConnPolicyText, AReaderIsSatisfiedByItsKindAndAnyOrTheSameCapacity) {
  const ReaderPolicy fifo8{ReaderPolicy::Kind::fifo, 8};
  EXPECT_TRUE(rtm::satisfies(fifo8, {ReaderPolicy::Kind::any, 0}));
  EXPECT_TRUE(rtm::satisfies(fifo8, {ReaderPolicy::Kind::fifo, 0}));
  EXPECT_TRUE(rtm::satisfies(fifo8, fifo8));
  EXPECT_FALSE(rtm::satisfies(fifo8, {ReaderPolicy::Kind::fifo, 16}));
  EXPECT_FALSE(rtm::satisfies(fifo8, {ReaderPolicy::Kind::latest, 0}));
}

TEST(ConnPolicyIdl, ValuesOutOfRangeFromTheWireAreRefusedNotTrusted) {
  RTM::ConnPolicy wire = rtm::to_idl(rtm::parse_conn_policy("once reader=fifo:4 depth=9 delivery=thread call=7ms"));
  EXPECT_EQ(rtm::to_string(rtm::from_idl(wire)), "once reader=fifo:4 depth=9 delivery=thread call=7ms");
  // omniORB refuses an enumerator beyond the IDL's when it unmarshals one (MARSHAL); inside the
  // C++ enum's range one can still be unnamed (3 of ConnDelivery's 0..3), as a newer build's
  // would be.
  RTM::ConnPolicy bad_delivery = wire;
  bad_delivery.delivery = static_cast<RTM::ConnDelivery>(3);
  EXPECT_THROW(rtm::from_idl(bad_delivery), std::invalid_argument);
  RTM::ConnPolicy deep = wire;
  deep.depth = 1u << 30;
  EXPECT_THROW(rtm::from_idl(deep), std::invalid_argument);
}

}  // namespace
