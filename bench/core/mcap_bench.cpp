// SPDX-License-Identifier: Apache-2.0
// The MCAP writer and reader (src/mcap) on their own, and with the recorder's per-datum work
// (a TimedFloat6 in a CORBA::Any turned into CDR). Figures: docs/performance.md.
//   rtm_bench_mcap [--benchmark_filter=...]     (RTM_BENCH_DIR: where the files go, default /tmp)
//
// BM_Write/<compression>: data per second into a file, each chunk compressed as it fills; the
//   bare floor beside them: BM_AppendOnly, the same records appended to a vector.
// BM_RecordTimedFloat6: to_cdr() of an Any, then the write (zstd): the recorder's work per datum.
// BM_ReadRange: 500 data (1 s of a 2 ms port) from the middle of a file of ~1 GB, through the
//   chunk indexes: opening the file (footer, summary) and reading them, page cache warm.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "RTM.hh"
#include "mcap/reader.h"
#include "mcap/writer.h"
#include "rtm/cdr.h"
#include "rtm/orb.h"

namespace {

namespace mcap = rtm::mcap;

std::string bench_file(const std::string& name) {
  const char* dir = std::getenv("RTM_BENCH_DIR");
  return (std::filesystem::path(dir != nullptr ? dir : "/tmp") / name).string();
}

// The CDR of a TimedFloat6 (36 bytes), varied a little per datum as real data is.
std::vector<std::uint8_t> datum(std::uint32_t n) {
  std::vector<std::uint8_t> d(36);
  for (std::size_t i = 0; i < d.size(); ++i) d[i] = static_cast<std::uint8_t>(i < 4 ? (i == 1) : n * 7 + i);
  return d;
}

void BM_Write(benchmark::State& state) {
  const auto compression = static_cast<mcap::Compression>(state.range(0));
  const auto path = bench_file("rtm-bench-write.mcap");
  mcap::WriterOptions options;
  options.compression = compression;
  std::vector<std::vector<std::uint8_t>> data;
  for (std::uint32_t n = 0; n < 1024; ++n) data.push_back(datum(n));
  std::uint64_t written = 0;
  for (auto _ : state) {
    mcap::Writer w(path, options);
    const auto schema = w.add_schema("RTM::TimedFloat6", "omgidl", "module RTM {};");
    const std::uint16_t channels[4] = {w.add_channel(schema, "a", "cdr"), w.add_channel(schema, "b", "cdr"),
                                       w.add_channel(schema, "c", "cdr"), w.add_channel(schema, "d", "cdr")};
    for (std::uint32_t n = 0; n < 200'000; ++n) {
      const std::uint64_t t = 1'700'000'000'000'000'000ULL + n * 500'000ULL;
      w.write(channels[n % 4], n, t, t + 40'000, data[n % data.size()]);
    }
    w.close();
    written += 200'000;
    state.counters["bytes_per_datum"] = static_cast<double>(w.bytes_written()) / 200'000;
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(written));
  std::filesystem::remove(path);
}
BENCHMARK(BM_Write)
    ->Arg(static_cast<int>(mcap::Compression::none))
    ->Arg(static_cast<int>(mcap::Compression::lz4))
    ->Arg(static_cast<int>(mcap::Compression::zstd))
    ->Unit(benchmark::kMillisecond);

// The floor: each datum's record bytes appended to memory, nothing else.
void BM_AppendOnly(benchmark::State& state) {
  std::vector<std::vector<std::uint8_t>> data;
  for (std::uint32_t n = 0; n < 1024; ++n) data.push_back(datum(n));
  std::vector<std::uint8_t> buffer;
  buffer.reserve(200'000 * 70);
  for (auto _ : state) {
    buffer.clear();
    for (std::uint32_t n = 0; n < 200'000; ++n) {
      const auto& d = data[n % data.size()];
      buffer.resize(buffer.size() + 31);  // the message record's header
      buffer.insert(buffer.end(), d.begin(), d.end());
    }
    benchmark::DoNotOptimize(buffer.data());
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) * 200'000);
}
BENCHMARK(BM_AppendOnly)->Unit(benchmark::kMillisecond);

void BM_RecordTimedFloat6(benchmark::State& state) {
  const rtm::Orb orb;
  const auto path = bench_file("rtm-bench-record.mcap");
  mcap::Writer w(path);
  const auto channel = w.add_channel(w.add_schema("RTM::TimedFloat6", "omgidl", rtm::idl_text(RTM::_tc_TimedFloat6)),
                                     "sensor0.out0", "cdr");
  RTM::TimedFloat6 v{};
  std::vector<std::uint8_t> cdr;
  std::uint32_t n = 0;
  for (auto _ : state) {
    v.tm.nsec = n;
    v.val[0] = static_cast<float>(n);
    CORBA::Any any;
    any <<= v;
    rtm::to_cdr(any, cdr);
    w.write(channel, n, n, n, cdr);
    ++n;
  }
  w.close();
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()));
  std::filesystem::remove(path);
}
BENCHMARK(BM_RecordTimedFloat6);

// ~1 GB: 1 M data of 1 KiB (an image row, a point cloud slice: what makes recordings big), 4
// ports at 2 ms each, uncompressed so that the file is that big on disk.
constexpr std::uint32_t kBigCount = 1'000'000;
const std::string& big_file() {
  static const std::string path = [] {
    const auto p = bench_file("rtm-bench-1gb.mcap");
    mcap::WriterOptions options;
    options.compression = mcap::Compression::none;
    options.chunk_size = 4 << 20;
    mcap::Writer w(p, options);
    const auto schema = w.add_schema("Blob", "omgidl", "struct Blob { octet b[1020]; };");
    std::uint16_t channels[4];
    for (int c = 0; c < 4; ++c) channels[c] = w.add_channel(schema, "port" + std::to_string(c), "cdr");
    std::vector<std::uint8_t> blob(1024, 0x5A);
    for (std::uint32_t n = 0; n < kBigCount; ++n) {
      const std::uint64_t t = n / 4 * 2'000'000ULL;
      w.write(channels[n % 4], n, t, t, blob);
    }
    w.close();
    return p;
  }();
  return path;
}

void BM_ReadRange(benchmark::State& state) {
  const auto& path = big_file();
  const std::uint64_t middle = std::uint64_t{kBigCount} / 4 / 2 * 2'000'000ULL;
  std::uint64_t got = 0;
  for (auto _ : state) {
    const mcap::Reader r(path);
    // One second of one port.
    const auto* port = r.channel("port1");
    got = 0;
    r.read_messages({middle, middle + 999'999'999ULL}, [&](const mcap::Message& m) { got += m.channel_id == port->id; });
  }
  state.counters["data"] = static_cast<double>(got);
  state.counters["file_GB"] = static_cast<double>(std::filesystem::file_size(path)) / 1e9;
}
BENCHMARK(BM_ReadRange)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
