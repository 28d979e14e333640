// SPDX-License-Identifier: Apache-2.0
// Start time (exec -> "bound" line) and idle RSS of a component process: rtm-example-source,
// started again and again against a real omniNames on a free port.
//
//   rtm_bench_startup [--runs N]
//
// exec -> bound: from just before fork to the moment its "bound ..." log line is read.
// Idle RSS: VmRSS from /proc/<pid>/status one second after it is bound, component off.
#include "rtm_test/child_process.h"
#include "rtm_test/omni_names.h"

#include "bench_stats.h"

#include <fstream>
#include <string>
#include <thread>

namespace {

long vm_rss_kb(pid_t pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
  }
  return -1;
}

}  // namespace

int main(int argc, char** argv) {
  int runs = 20;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (std::string(argv[i]) == "--runs") runs = std::stoi(argv[i + 1]);
  }
  rtm_test::OmniNames names;
  std::vector<std::int64_t> start_ns;
  std::vector<std::int64_t> rss_kb;
  for (int run = 0; run < runs; ++run) {
    rtm_test::ChildProcess::Options options;
    options.echo_output = false;
    const auto before = rtm_bench::monotonic_ns();
    rtm_test::ChildProcess process({RTM_EXAMPLE_SOURCE, "--name", "startup" + std::to_string(run), "--naming",
                                    names.address()},
                                   options);
    process.wait_until_bound();
    start_ns.push_back(rtm_bench::monotonic_ns() - before);
    std::this_thread::sleep_for(std::chrono::seconds(1));
    rss_kb.push_back(vm_rss_kb(process.pid()));
    process.stop();
  }
  auto start = rtm_bench::summarize(start_ns);
  std::printf("rtm-example-source, %d runs\n", runs);
  std::printf("exec -> bound     p50 %.2f ms  max %.2f ms\n", start.p50_us / 1e3, start.max_us / 1e3);
  auto rss = rtm_bench::summarize(rss_kb);
  std::printf("idle VmRSS        p50 %.1f MB  max %.1f MB\n", rss.p50_us * 1e3 / 1024.0, rss.max_us * 1e3 / 1024.0);
  return 0;
}
