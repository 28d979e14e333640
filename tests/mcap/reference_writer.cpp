// SPDX-License-Identifier: Apache-2.0
// Writes an MCAP file of RTM data (the paper's type, the added ones and user IDL types), each
// channel with its IDL as an omgidl schema and each datum as CDR, and beside it the JSON that a
// reader must decode from it (the shape tests/mcap/reference/read.mjs prints). The reference
// test compares the two.
//   reference_writer write OUT.mcap none|lz4|zstd EXPECTED.json
//   reference_writer recover DAMAGED.mcap OUT.mcap      (prints the messages recovered)
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <iostream>
#include <limits>

#include "RTMData.hh"
#include "mcap/reader.h"
#include "mcap/writer.h"
#include "rtm/cdr.h"
#include "rtm/data.h"
#include "rtm/orb.h"
#include "test_types.hh"

namespace {

using nlohmann::json;

json time_json(const RTM::Time& t) { return {{"sec", t.sec}, {"nsec", t.nsec}}; }

json float_json(double v) {
  if (std::isnan(v)) return "NaN";
  if (std::isinf(v)) return v > 0 ? "Infinity" : "-Infinity";
  return v;
}

class Recording {
 public:
  Recording(const std::string& path, rtm::mcap::Compression compression)
      : writer_(path, options(compression)) {}

  std::uint16_t channel(CORBA::TypeCode_ptr tc, const std::string& topic) {
    const auto schema = writer_.add_schema(rtm::type_name(tc), "omgidl", rtm::idl_text(tc));
    return writer_.add_channel(schema, topic, "cdr", {{"type", rtm::type_name(tc)}});
  }

  template <typename T>
  void write(std::uint16_t channel, const std::string& topic, const T& value, json decoded) {
    CORBA::Any any;
    any <<= value;
    const auto bytes = rtm::to_cdr(any);
    const std::uint64_t log_time = 1'700'000'000'000'000'000ULL + sequence_ * 2'000'000ULL;
    writer_.write(channel, sequence_, log_time, log_time + 150'000, bytes);
    expected_.push_back({{"channelId", channel},
                         {"topic", topic},
                         {"sequence", sequence_},
                         {"logTime", std::to_string(log_time)},
                         {"publishTime", std::to_string(log_time + 150'000)},
                         {"data", std::move(decoded)}});
    ++sequence_;
  }

  json close() {
    writer_.add_metadata("system", {{"components", "sensor0 controller0"}});
    writer_.close();
    return {{"library", "rtm"}, {"messages", expected_}};
  }

 private:
  static rtm::mcap::WriterOptions options(rtm::mcap::Compression compression) {
    rtm::mcap::WriterOptions o;
    o.compression = compression;
    o.chunk_size = 2048;  // several chunks
    return o;
  }

  rtm::mcap::Writer writer_;
  json expected_ = json::array();
  std::uint32_t sequence_ = 0;
};

void write_all(Recording& r) {
  const auto wrench = r.channel(RTM::_tc_TimedFloat6, "sensor0.out0");
  const auto seq = r.channel(RTM::_tc_TimedDoubleSeq, "controller0.log");
  const auto pose = r.channel(RtmTest::_tc_TimedPose, "arm.pose");
  const auto mixed = r.channel(RtmTest::_tc_TimedMixed, "mixed");
  const auto scalars = r.channel(RtmTest::_tc_TimedScalars, "scalars");
  const auto path = r.channel(RtmTest::_tc_TimedPath, "path");
  for (CORBA::ULong n = 0; n < 40; ++n) {
    RTM::TimedFloat6 w;
    w.tm = {1'700'000'000 + n, n * 1000};
    json val = json::array();
    for (CORBA::ULong i = 0; i < 6; ++i) {
      w.val[i] = (n == 3 && i == 2) ? std::numeric_limits<float>::quiet_NaN() : 0.1F * static_cast<float>(n * i) - 2;
      val.push_back(float_json(w.val[i]));
    }
    r.write(wrench, "sensor0.out0", w, {{"tm", time_json(w.tm)}, {"val", val}});

    RTM::TimedDoubleSeq d;
    d.tm = {n, 7};
    d.data.length(n % 4);
    json data = json::array();
    for (CORBA::ULong i = 0; i < d.data.length(); ++i) {
      d.data[i] = 1.0 / (n + i + 1);
      data.push_back(d.data[i]);
    }
    r.write(seq, "controller0.log", d, {{"tm", time_json(d.tm)}, {"data", data}});

    if (n % 4 == 0) {
      RtmTest::TimedPose p;
      p.tm = {n, 0};
      p.p = {0.5 * n, -1.25, 3.0};
      json q = json::array();
      for (CORBA::ULong i = 0; i < 4; ++i) q.push_back(p.q[i] = 0.25 * i);
      r.write(pose, "arm.pose", p, {{"tm", time_json(p.tm)}, {"p", {{"x", p.p.x}, {"y", p.p.y}, {"z", p.p.z}}}, {"q", q}});

      RtmTest::TimedMixed m;
      m.tm = {n, 1};
      m.n = -static_cast<CORBA::Long>(n);
      m.on = n % 8 == 0;
      m.mode = n % 8 == 0 ? RtmTest::RUN : RtmTest::IDLE;
      m.data.length(2);
      m.data[0] = 1.5F;
      m.data[1] = static_cast<float>(n);
      r.write(mixed, "mixed", m,
              {{"tm", time_json(m.tm)}, {"n", m.n}, {"on", static_cast<bool>(m.on)}, {"mode", m.mode == RtmTest::RUN ? 1 : 0},
               {"data", {1.5, static_cast<double>(n)}}});

      RtmTest::TimedScalars s;
      s.tm = {n, 2};
      s.s = -300;
      s.us = 60000;
      s.ul = 4'000'000'000U;
      s.ll = -9'000'000'000'000LL - n;
      s.ull = 18'000'000'000'000'000'000ULL + n;
      s.o = 200;
      s.c = 'A';
      s.f = 0.1F;
      s.label = CORBA::string_dup(n % 8 == 0 ? "pressing" : "");
      r.write(scalars, "scalars", s,
              {{"tm", time_json(s.tm)}, {"s", s.s}, {"us", s.us}, {"ul", s.ul}, {"ll", std::to_string(s.ll)},
               {"ull", std::to_string(s.ull)}, {"o", 200}, {"c", 65}, {"f", static_cast<double>(0.1F)},
               {"label", std::string(s.label)}});

      RtmTest::TimedPath pt;
      pt.tm = {n, 3};
      pt.points.length(n % 3);
      json points = json::array();
      for (CORBA::ULong i = 0; i < pt.points.length(); ++i) {
        pt.points[i] = {1.0 * i, 2.0 * n, -0.5};
        points.push_back({{"x", pt.points[i].x}, {"y", pt.points[i].y}, {"z", pt.points[i].z}});
      }
      r.write(path, "path", pt, {{"tm", time_json(pt.tm)}, {"points", points}});
    }
  }
}

}  // namespace

int main(int argc, char** argv) try {
  const rtm::Orb orb;  // CDR's character code sets
  const std::string verb = argc > 1 ? argv[1] : "";
  if (verb == "write" && argc == 5) {
    Recording r(argv[2], rtm::mcap::compression_from_name(std::string(argv[3]) == "none" ? "" : argv[3]));
    write_all(r);
    std::ofstream(argv[4]) << r.close().dump(1) << "\n";
    return 0;
  }
  if (verb == "recover" && argc == 4) {
    const auto found = rtm::mcap::recover_to(argv[2], argv[3]);
    std::cout << found.message_count << "\n";
    return 0;
  }
  std::cerr << "usage: reference_writer write OUT.mcap none|lz4|zstd EXPECTED.json\n"
               "       reference_writer recover DAMAGED.mcap OUT.mcap\n";
  return 2;
} catch (const std::exception& e) {
  std::cerr << "reference_writer: " << e.what() << "\n";
  return 1;
}
