// SPDX-License-Identifier: Apache-2.0
// A port's type as IDL text and its data as CDR, the encodings a recording carries. The bytes
// are checked against the layout the CDR rules fix (each primitive aligned to its size from the
// byte after the 4-byte header); tests/mcap/reference checks them against Foxglove's decoder.
#include "rtm/cdr.h"

#include <gtest/gtest.h>

#include <cstring>

#include "RTMData.hh"
#include "rtm/data.h"
#include "rtm_test/orb_environment.h"
#include "test_types.hh"

namespace {

const auto* const kOrb = ::testing::AddGlobalTestEnvironment(new rtm_test::OrbEnvironment);

template <typename T>
T read_at(const std::vector<std::uint8_t>& bytes, std::size_t at) {
  T v;
  std::memcpy(&v, bytes.data() + at, sizeof v);
  return v;
}

TEST(IdlText, ThePapersTypeIsWrittenWithEverythingItNeedsInItsModule) {
  EXPECT_EQ(rtm::idl_text(RTM::_tc_TimedFloat6),
            "module RTM {\n"
            "  struct Time {\n"
            "    unsigned long sec;\n"
            "    unsigned long nsec;\n"
            "  };\n"
            "  typedef float Float6[6];\n"
            "  struct TimedFloat6 {\n"
            "    RTM::Time tm;\n"
            "    RTM::Float6 val;\n"
            "  };\n"
            "};\n");
}

TEST(IdlText, AUserTypeNamesTypesOfOtherModulesAndDefinesEachOnce) {
  const auto idl = rtm::idl_text(RtmTest::_tc_TimedMixed);
  EXPECT_NE(idl.find("module RTM {\n  struct Time {"), std::string::npos) << idl;
  EXPECT_NE(idl.find("module RtmTest {\n  enum RunMode { IDLE, RUN };"), std::string::npos) << idl;
  EXPECT_NE(idl.find("    sequence<float> data;\n"), std::string::npos) << idl;
  EXPECT_NE(idl.find("    RtmTest::RunMode mode;\n"), std::string::npos) << idl;
  EXPECT_EQ(idl.find("struct Time {"), idl.rfind("struct Time {")) << idl;

  const auto scalars = rtm::idl_text(RtmTest::_tc_TimedScalars);
  for (const char* member : {"short s;", "unsigned short us;", "unsigned long ul;", "long long ll;",
                             "unsigned long long ull;", "octet o;", "char c;", "float f;", "string label;"}) {
    EXPECT_NE(scalars.find(member), std::string::npos) << member << " in\n" << scalars;
  }
}

TEST(IdlText, ATypeNoOmgidlReaderDecodesIsRefusedNamingWhere) {
  static CORBA::TypeCode::_Tracker tracker(__FILE__);  // owns the TypeCodes made here, as stubs do
  const CORBA::PR_structMember members[] = {{"label", CORBA::_tc_wstring}};
  CORBA::TypeCode_ptr tc = CORBA::TypeCode::PR_struct_tc("IDL:Test/Wide:1.0", "Wide", members, 1, &tracker);
  try {
    rtm::idl_text(tc);
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("Test::Wide.label holds wstring"), std::string::npos) << e.what();
  }
  EXPECT_THROW(rtm::idl_text(CORBA::TypeCode::_nil()), std::invalid_argument);
}

TEST(Cdr, TheHeaderSaysLittleEndianCdrAndEachFieldIsWhereTheRulesPutIt) {
  RTM::TimedFloat6 v;
  v.tm.sec = 7;
  v.tm.nsec = 500;
  for (CORBA::ULong i = 0; i < 6; ++i) v.val[i] = 1.5F * static_cast<float>(i);
  CORBA::Any any;
  any <<= v;
  const auto bytes = rtm::to_cdr(any);
  ASSERT_EQ(bytes.size(), 4u + 8u + 24u);
  EXPECT_EQ(bytes[0], 0x00);
  EXPECT_EQ(bytes[1], 0x01);
  EXPECT_EQ(read_at<std::uint32_t>(bytes, 4), 7u);
  EXPECT_EQ(read_at<std::uint32_t>(bytes, 8), 500u);
  EXPECT_EQ(read_at<float>(bytes, 12 + 4 * 5), 7.5F);

  // A double after a 4-byte sequence length is aligned to 8 from the byte after the header.
  RTM::TimedDoubleSeq d;
  d.tm.sec = 1;
  d.tm.nsec = 2;
  d.data.length(2);
  d.data[0] = 0.25;
  d.data[1] = -3.0;
  CORBA::Any seq;
  seq <<= d;
  const auto s = rtm::to_cdr(seq);
  ASSERT_EQ(s.size(), 4u + 8u + 4u + 4u + 16u);  // header, tm, length, padding, doubles
  EXPECT_EQ(read_at<std::uint32_t>(s, 12), 2u);
  EXPECT_EQ(read_at<std::uint32_t>(s, 16), 0u) << "padding is zero: no stale memory in a recording";
  EXPECT_EQ(read_at<double>(s, 20), 0.25);
  EXPECT_EQ(read_at<double>(s, 28), -3.0);
}

TEST(Cdr, AUserTypeComesBackAsTheSameValue) {
  RtmTest::TimedMixed m;
  m.tm.sec = 3;
  m.tm.nsec = 4;
  m.n = -12;
  m.on = true;
  m.mode = RtmTest::RUN;
  m.data.length(3);
  for (CORBA::ULong i = 0; i < 3; ++i) m.data[i] = static_cast<float>(i) + 0.5F;
  CORBA::Any any;
  any <<= m;
  const auto bytes = rtm::to_cdr(any);
  const CORBA::Any back = rtm::from_cdr(RtmTest::_tc_TimedMixed, bytes);
  const RtmTest::TimedMixed* got = nullptr;
  ASSERT_TRUE(back >>= got);
  EXPECT_EQ(got->n, -12);
  EXPECT_TRUE(got->on);
  EXPECT_EQ(got->mode, RtmTest::RUN);
  ASSERT_EQ(got->data.length(), 3u);
  EXPECT_EQ(got->data[2], 2.5F);
}

TEST(Cdr, BytesThatAreNotAWholeValueAreRefused) {
  RTM::TimedFloat6 v{};
  CORBA::Any any;
  any <<= v;
  auto bytes = rtm::to_cdr(any);
  EXPECT_THROW(rtm::from_cdr(RTM::_tc_TimedFloat6, std::span(bytes).first(bytes.size() - 1)), std::invalid_argument);
  auto longer = bytes;
  longer.resize(bytes.size() + 8);
  EXPECT_THROW(rtm::from_cdr(RTM::_tc_TimedFloat6, longer), std::invalid_argument);
  auto bad_header = bytes;
  bad_header[1] = 0x07;
  EXPECT_THROW(rtm::from_cdr(RTM::_tc_TimedFloat6, bad_header), std::invalid_argument);
  // A sequence that claims more elements than there are bytes.
  RTM::TimedDoubleSeq d{};
  d.data.length(1);
  CORBA::Any seq;
  seq <<= d;
  auto s = rtm::to_cdr(seq);
  const std::uint32_t huge = 0x10000000;
  std::memcpy(s.data() + 12, &huge, sizeof huge);
  EXPECT_THROW(rtm::from_cdr(RTM::_tc_TimedDoubleSeq, s), std::invalid_argument);
}

}  // namespace

namespace {

TEST(Cdr, EveryBasicKindAndAStringComeBack) {
  RtmTest::TimedScalars s;
  s.tm.sec = 1;
  s.tm.nsec = 2;
  s.s = -300;
  s.us = 60000;
  s.ul = 4'000'000'000U;
  s.ll = -9'000'000'000'000LL;
  s.ull = 18'000'000'000'000'000'000ULL;
  s.o = 200;
  s.c = 'A';
  s.f = 0.1F;
  s.label = CORBA::string_dup("pressing");
  CORBA::Any any;
  any <<= s;
  const CORBA::Any back = rtm::from_cdr(RtmTest::_tc_TimedScalars, rtm::to_cdr(any));
  const RtmTest::TimedScalars* got = nullptr;
  ASSERT_TRUE(back >>= got);
  EXPECT_EQ(got->ll, s.ll);
  EXPECT_EQ(got->ull, s.ull);
  EXPECT_EQ(got->c, 'A');
  EXPECT_STREQ(got->label, "pressing");
}

}  // namespace

namespace {

TEST(TypeCodeText, AUserTypeComesBackEquivalentAndDecodesItsData) {
  const auto text = rtm::type_code_text(RtmTest::_tc_TimedPath);
  CORBA::TypeCode_var back = rtm::type_code_from_text(text);
  EXPECT_TRUE(back->equivalent(RtmTest::_tc_TimedPath));
  EXPECT_EQ(rtm::type_name(back), "RtmTest::TimedPath");

  RtmTest::TimedPath path;
  path.tm.sec = 9;
  path.tm.nsec = 0;
  path.points.length(2);
  path.points[0] = {1.0, 2.0, 3.0};
  path.points[1] = {0.0, 0.0, -0.5};
  CORBA::Any any;
  any <<= path;
  const CORBA::Any decoded = rtm::from_cdr(back, rtm::to_cdr(any));
  CORBA::TypeCode_var decoded_type = decoded.type();
  EXPECT_TRUE(decoded_type->equivalent(RtmTest::_tc_TimedPath));
  EXPECT_EQ(rtm::to_cdr(decoded), rtm::to_cdr(any)) << "the same bytes again";
}

TEST(TypeCodeText, TextThatIsNotATypeCodeIsRefused) {
  EXPECT_THROW(rtm::type_code_from_text("abc"), std::invalid_argument);
  EXPECT_THROW(rtm::type_code_from_text("zz"), std::invalid_argument);
  EXPECT_THROW(rtm::type_code_from_text("ffffffff00000010"), std::invalid_argument);
  auto text = rtm::type_code_text(RTM::_tc_TimedFloat6);
  EXPECT_THROW(rtm::type_code_from_text(text.substr(0, text.size() / 2)), std::invalid_argument);
}

}  // namespace
