// SPDX-License-Identifier: Apache-2.0
// What logging a component's cycles costs the cycle, and how fast a replay steps through them
// (host/cycle_log.h; docs/performance.md, "Re-simulation").
//
//   BM_Cycle/0   a cycle of the controller's arithmetic (two reads, gain*(a+b), one write),
//                its inputs delivered in-process before it: the bare floor
//   BM_Cycle/1   the same with --log-cycles' taps and writer thread (flushed every 1000 cycles
//                outside the timing: the loop runs far faster than any real period)
//   BM_Replay    a log of 30 000 such cycles (60 s at 2 ms) replayed: x_real_time is the logged
//                time over the stepping's (rtm replay's figure), x_real_time_whole over the whole
//                call's, reading and decompressing the file included
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>

#include "host/cycle_log.h"
#include "rtm/component.h"
#include "rtm/orb.h"

namespace {

constexpr std::int64_t kPeriod = 2'000'000;

// The controller's law on two TimedFloat6 inputs; the sensor's stamp passed on.
class Law final : public rtm::Component {
 public:
  Law() : Component("law0", "law") {}
  void on_cycle(const rtm::CycleContext&) override {
    const bool fresh = sensor.read(sensor_datum_) == rtm::ReadResult::NewData;
    reference.read(reference_datum_);
    if (!fresh) return;
    for (CORBA::ULong i = 0; i < 6; ++i) command_.val[i] = 0.0004f * (reference_datum_.val[i] + sensor_datum_.val[i]);
    command_.tm = sensor_datum_.tm;
    out.write(command_);
  }
  rtm::InPort<RTM::TimedFloat6>& sensor = add_in_port<RTM::TimedFloat6>("wrench");
  rtm::InPort<RTM::TimedFloat6>& reference = add_in_port<RTM::TimedFloat6>("reference");
  rtm::OutPort<RTM::TimedFloat6>& out = add_out_port<RTM::TimedFloat6>("twist");

 private:
  RTM::TimedFloat6 sensor_datum_{}, reference_datum_{}, command_{};
};

RTM::TimedFloat6 datum(std::uint64_t k, float base) {
  RTM::TimedFloat6 d{};
  const std::int64_t ns = 5'000'000'000 + static_cast<std::int64_t>(k) * kPeriod;
  d.tm.sec = static_cast<CORBA::ULong>(ns / 1'000'000'000);
  d.tm.nsec = static_cast<CORBA::ULong>(ns % 1'000'000'000);
  for (CORBA::ULong i = 0; i < 6; ++i) d.val[i] = base + static_cast<float>(k % 97) * 0.01f * static_cast<float>(i);
  return d;
}

rtm::CycleContext context(std::uint64_t k) {
  rtm::CycleContext ctx;
  ctx.cycle = k;
  ctx.period_ns = kPeriod;
  ctx.deadline_ns = 1'000'000'000 + static_cast<std::int64_t>(k) * kPeriod;
  ctx.wake_ns = ctx.deadline_ns + 40'000;
  return ctx;
}

std::string temp_file(const char* name) {
  return (std::filesystem::temp_directory_path() / (std::string(name) + "-" + std::to_string(::getpid()) + ".mcap")).string();
}

constexpr std::uint64_t kBatch = 1000;  // cycles between two flushes: within the log's slots

// Runs Law's cycles, logged into `path` when it is not empty: each benchmark iteration (or, with
// no state, each of cycles / kBatch rounds) is kBatch cycles, after which the log is flushed
// outside the timing, so that a loop far faster than a real period loses nothing.
void run(benchmark::State* state, std::uint64_t cycles, const std::string& path) {
  rtm::ComponentServant servant(std::make_unique<Law>(), rtm::ExternalTick{});
  auto& law = static_cast<Law&>(servant.component());
  std::unique_ptr<rtm::CycleLog> log;
  if (!path.empty()) log = std::make_unique<rtm::CycleLog>(servant, path);
  servant.on();
  const rtm::CycleFunction step = servant.cycle_function();
  std::uint64_t k = 0;
  const auto batch = [&] {
    for (std::uint64_t i = 0; i < kBatch; ++i, ++k) {
      law.sensor.deliver(datum(k, -9.0f));
      law.reference.deliver(datum(k, 10.0f));
      step(context(k));
    }
  };
  if (state != nullptr) {
    for (auto _ : *state) {
      batch();
      if (log) {
        state->PauseTiming();
        log->flush();
        state->ResumeTiming();
      }
    }
    state->SetItemsProcessed(static_cast<std::int64_t>(k));
  } else {
    while (k < cycles) {
      batch();
      if (log) log->flush();
    }
  }
  servant.off();
  if (log && log->lost() > 0) {
    if (state != nullptr) state->SkipWithError("the log lost data");
    else std::fprintf(stderr, "the log lost %llu events or data\n", static_cast<unsigned long long>(log->lost()));
  }
}

void BM_Cycle(benchmark::State& state) {
  const bool logged = state.range(0) != 0;
  const std::string path = logged ? temp_file("rtm-bench-cycles") : std::string();
  run(&state, 0, path);
  if (logged) std::filesystem::remove(path);
}
BENCHMARK(BM_Cycle)->Arg(0)->Arg(1);

void BM_Replay(benchmark::State& state) {
  constexpr std::uint64_t kCycles = 30'000;
  const std::string path = temp_file("rtm-bench-replay");
  run(nullptr, kCycles, path);
  std::uint64_t differing = 0, stepped = 0;
  std::int64_t logged_ns = 0;
  double replay_s = 0, whole_s = 0;
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    const rtm::ReplayResult r = rtm::replay_cycle_log(std::make_unique<Law>(), path);
    whole_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    differing += r.differing + r.unjudged;
    stepped += r.cycles;
    logged_ns += r.logged_span_ns;
    replay_s += r.replay_seconds;
  }
  std::filesystem::remove(path);
  state.counters["x_real_time"] = static_cast<double>(logged_ns) * 1e-9 / replay_s;
  state.counters["x_real_time_whole"] = static_cast<double>(logged_ns) * 1e-9 / whole_s;
  state.counters["differing_or_unjudged"] = static_cast<double>(differing);
  state.SetItemsProcessed(static_cast<std::int64_t>(stepped));
}
BENCHMARK(BM_Replay)->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  const rtm::Orb orb;  // the encodings' code sets
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
