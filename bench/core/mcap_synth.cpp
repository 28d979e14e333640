// SPDX-License-Identifier: Apache-2.0
// A recording made up for the playback figures: one TimedFloat6 port ("synthetic.out") stamped
// on a grid, as rtm record writes it (its IDL as an omgidl schema, each datum CDR).
//   rtm_bench_mcap_synth OUT.mcap SECONDS [PERIOD_MS]     (default period: 2 ms)
// Then: rtm play OUT.mcap --map synthetic.out=<component>.<InPort> --json (docs/performance.md).
#include <cstdlib>
#include <iostream>
#include <string>

#include "RTM.hh"
#include "mcap/writer.h"
#include "rtm/cdr.h"
#include "rtm/orb.h"

int main(int argc, char** argv) try {
  if (argc < 3) {
    std::cerr << "usage: rtm_bench_mcap_synth OUT.mcap SECONDS [PERIOD_MS]\n";
    return 2;
  }
  const double seconds = std::stod(argv[2]);
  const double period_ms = argc > 3 ? std::stod(argv[3]) : 2.0;
  const rtm::Orb orb;
  rtm::mcap::Writer w(argv[1]);
  const auto schema = w.add_schema("RTM::TimedFloat6", "omgidl", rtm::idl_text(RTM::_tc_TimedFloat6));
  const auto channel = w.add_channel(schema, "synthetic.out", "cdr", {{"type", "RTM::TimedFloat6"}});
  const auto period_ns = static_cast<std::uint64_t>(period_ms * 1e6);
  const auto count = static_cast<std::uint32_t>(seconds * 1e3 / period_ms);
  const std::uint64_t start = 1'700'000'000'000'000'000ULL;
  RTM::TimedFloat6 v{};
  std::vector<std::uint8_t> cdr;
  for (std::uint32_t n = 0; n < count; ++n) {
    const std::uint64_t t = start + n * period_ns;
    v.tm.sec = static_cast<CORBA::ULong>(t / 1'000'000'000ULL);
    v.tm.nsec = static_cast<CORBA::ULong>(t % 1'000'000'000ULL);
    for (CORBA::ULong i = 0; i < 6; ++i) v.val[i] = static_cast<float>(n + i);
    CORBA::Any any;
    any <<= v;
    rtm::to_cdr(any, cdr);
    w.write(channel, n, t, t, cdr);
  }
  w.close();
  std::cout << count << " data over " << seconds << " s in " << argv[1] << "\n";
  return 0;
} catch (const std::exception& e) {
  std::cerr << "rtm_bench_mcap_synth: " << e.what() << "\n";
  return 1;
}
