#include "components/actuator/latency_histogram.h"

#include <cmath>

namespace rtm::comp {

std::size_t LatencyHistogram::bucket_of(std::int64_t ns) {
  if (ns < 0) ns = 0;
  if (ns < 1'000'000) return static_cast<std::size_t>(ns / 1'000);
  if (ns < 10'000'000) return kMicroBuckets + static_cast<std::size_t>((ns - 1'000'000) / 100'000);
  if (ns < 1'000'000'000)
    return kMicroBuckets + kTenthBuckets + static_cast<std::size_t>((ns - 10'000'000) / 1'000'000);
  return kBuckets - 1;
}

std::int64_t LatencyHistogram::upper_edge_ns(std::size_t bucket) {
  if (bucket < kMicroBuckets) return static_cast<std::int64_t>(bucket + 1) * 1'000;
  bucket -= kMicroBuckets;
  if (bucket < kTenthBuckets) return 1'000'000 + static_cast<std::int64_t>(bucket + 1) * 100'000;
  bucket -= kTenthBuckets;
  if (bucket < kMilliBuckets) return 10'000'000 + static_cast<std::int64_t>(bucket + 1) * 1'000'000;
  return -1;
}

void LatencyHistogram::record(std::int64_t ns) {
  if (ns < 0) ns = 0;
  buckets_[bucket_of(ns)].fetch_add(1, std::memory_order_relaxed);
  count_.fetch_add(1, std::memory_order_relaxed);
  std::int64_t max = max_ns_.load(std::memory_order_relaxed);
  while (ns > max && !max_ns_.compare_exchange_weak(max, ns, std::memory_order_relaxed)) {
  }
}

std::int64_t LatencyHistogram::percentile_ns(double q) const {
  const std::uint64_t total = count();
  if (total == 0) return 0;
  const auto target = static_cast<std::uint64_t>(std::ceil(q * static_cast<double>(total)));
  const std::int64_t max = max_ns();
  std::uint64_t cumulative = 0;
  for (std::size_t i = 0; i < kBuckets; ++i) {
    cumulative += buckets_[i].load(std::memory_order_relaxed);
    if (cumulative >= target && cumulative > 0) {
      const std::int64_t upper = upper_edge_ns(i);
      return upper < 0 || upper > max ? max : upper;
    }
  }
  return max;
}

}  // namespace rtm::comp
