// SPDX-License-Identifier: Apache-2.0
// Lock-free, allocation-free histograms of durations [ns]: record() from one real-time thread
// (no lock, no allocation), percentiles and max from any thread meanwhile. The bucket layout is
// a parameter, so each figure gets the resolution it is read at:
//   LatenessHistogram  wake lateness of an activity: 1 us below 1 ms, 1 ms up to 1 s
//   LatencyHistogram   end-to-end latency over a few periods: 1 us below 1 ms, 100 us up to
//                      10 ms, 1 ms up to 1 s
// Both end with one open bucket. A percentile is the upper edge of the bucket holding it,
// capped at the largest value recorded (the open bucket: that value).
#pragma once

#include <array>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdint>

namespace rtm {

template <class Layout>
class DurationHistogram {
 public:
  void record(std::int64_t ns) {
    if (ns < 0) ns = 0;  // a clock step
    buckets_[bucket_of(ns)].fetch_add(1, std::memory_order_relaxed);
    count_.fetch_add(1, std::memory_order_relaxed);
    std::int64_t max = max_ns_.load(std::memory_order_relaxed);
    while (ns > max && !max_ns_.compare_exchange_weak(max, ns, std::memory_order_relaxed)) {
    }
  }

  // q in [0, 1]; 0 when empty.
  std::int64_t percentile_ns(double q) const {
    const std::uint64_t total = count();
    if (total == 0) return 0;
    const auto target = static_cast<std::uint64_t>(std::ceil(q * static_cast<double>(total)));
    const std::int64_t max = max_ns();
    std::uint64_t cumulative = 0;
    for (std::size_t i = 0; i < Layout::kBuckets; ++i) {
      cumulative += buckets_[i].load(std::memory_order_relaxed);
      if (cumulative >= target && cumulative > 0) {
        const std::int64_t upper = Layout::upper_edge_ns(i);
        return upper < 0 || upper > max ? max : upper;
      }
    }
    return max;
  }

  std::int64_t max_ns() const { return max_ns_.load(std::memory_order_relaxed); }
  std::uint64_t count() const { return count_.load(std::memory_order_relaxed); }

  void clear() {  // not concurrently with record()
    for (auto& b : buckets_) b.store(0, std::memory_order_relaxed);
    count_.store(0, std::memory_order_relaxed);
    max_ns_.store(0, std::memory_order_relaxed);
  }

  // The layout, for tests and reports.
  static std::size_t bucket_of(std::int64_t ns) { return Layout::bucket_of(ns < 0 ? 0 : ns); }
  static std::int64_t upper_edge_ns(std::size_t bucket) { return Layout::upper_edge_ns(bucket); }  // -1: open

 private:
  std::array<std::atomic<std::uint64_t>, Layout::kBuckets> buckets_{};
  std::atomic<std::uint64_t> count_{0};
  std::atomic<std::int64_t> max_ns_{0};
};

// [0, 1 ms) by 1 us, [1 ms, 1 s) by 1 ms, then open. ns >= 0.
struct LatenessLayout {
  static constexpr std::size_t kFine = 1000;
  static constexpr std::size_t kCoarse = 999;
  static constexpr std::size_t kBuckets = kFine + kCoarse + 1;
  static constexpr std::size_t bucket_of(std::int64_t ns) {
    if (ns < 1'000'000) return static_cast<std::size_t>(ns / 1'000);
    if (ns < 1'000'000'000) return kFine + static_cast<std::size_t>(ns / 1'000'000) - 1;
    return kBuckets - 1;
  }
  static constexpr std::int64_t upper_edge_ns(std::size_t bucket) {
    if (bucket < kFine) return static_cast<std::int64_t>(bucket + 1) * 1'000;
    if (bucket < kBuckets - 1) return static_cast<std::int64_t>(bucket - kFine + 2) * 1'000'000;
    return -1;
  }
};

// [0, 1 ms) by 1 us, [1 ms, 10 ms) by 100 us, [10 ms, 1 s) by 1 ms, then open. ns >= 0.
struct LatencyLayout {
  static constexpr std::size_t kMicro = 1000;
  static constexpr std::size_t kTenth = 90;
  static constexpr std::size_t kMilli = 990;
  static constexpr std::size_t kBuckets = kMicro + kTenth + kMilli + 1;
  static constexpr std::size_t bucket_of(std::int64_t ns) {
    if (ns < 1'000'000) return static_cast<std::size_t>(ns / 1'000);
    if (ns < 10'000'000) return kMicro + static_cast<std::size_t>((ns - 1'000'000) / 100'000);
    if (ns < 1'000'000'000) return kMicro + kTenth + static_cast<std::size_t>((ns - 10'000'000) / 1'000'000);
    return kBuckets - 1;
  }
  static constexpr std::int64_t upper_edge_ns(std::size_t bucket) {
    if (bucket < kMicro) return static_cast<std::int64_t>(bucket + 1) * 1'000;
    bucket -= kMicro;
    if (bucket < kTenth) return 1'000'000 + static_cast<std::int64_t>(bucket + 1) * 100'000;
    bucket -= kTenth;
    if (bucket < kMilli) return 10'000'000 + static_cast<std::int64_t>(bucket + 1) * 1'000'000;
    return -1;
  }
};

using LatenessHistogram = DurationHistogram<LatenessLayout>;
using LatencyHistogram = DurationHistogram<LatencyLayout>;

}  // namespace rtm
