// SPDX-License-Identifier: Apache-2.0
// Percentiles of a run of samples, printed the same way by every core benchmark.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <ctime>
#include <vector>

namespace rtm_bench {

inline std::int64_t monotonic_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return std::int64_t{ts.tv_sec} * 1'000'000'000 + ts.tv_nsec;
}

struct Summary {
  std::size_t count = 0;
  double p50_us = 0, p99_us = 0, max_us = 0, mean_us = 0;
};

// Sorts samples (ns) in place.
inline Summary summarize(std::vector<std::int64_t>& samples_ns) {
  Summary s;
  s.count = samples_ns.size();
  if (samples_ns.empty()) return s;
  std::sort(samples_ns.begin(), samples_ns.end());
  auto at = [&](double q) {
    const auto index = static_cast<std::size_t>(q * static_cast<double>(samples_ns.size() - 1));
    return static_cast<double>(samples_ns[index]) / 1e3;
  };
  s.p50_us = at(0.50);
  s.p99_us = at(0.99);
  s.max_us = static_cast<double>(samples_ns.back()) / 1e3;
  double sum = 0;
  for (auto v : samples_ns) sum += static_cast<double>(v);
  s.mean_us = sum / static_cast<double>(samples_ns.size()) / 1e3;
  return s;
}

inline void print_row(const char* label, const Summary& s) {
  std::printf("%-44s n=%-8zu p50 %8.2f us  p99 %8.2f us  max %9.2f us\n", label, s.count, s.p50_us, s.p99_us,
              s.max_us);
}

}  // namespace rtm_bench
