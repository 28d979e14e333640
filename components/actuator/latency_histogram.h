// Sample-to-drive latency histogram of the actuator: fine enough over the range the force
// servo lives in (up to a few 2 ms periods) that a percentile is a figure, not a bound.
// Buckets: 1 us below 1 ms, 100 us from 1 ms to 10 ms, 1 ms from 10 ms to 1 s, one above.
// record() is lock-free and allocation-free (the actuator's cycle); readers may run meanwhile.
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>

namespace rtm::comp {

class LatencyHistogram {
 public:
  void record(std::int64_t latency_ns);  // negative (clock step) counts as 0
  // Upper edge of the bucket holding the q-quantile, capped at the largest value recorded;
  // q in [0, 1]; 0 when empty.
  std::int64_t percentile_ns(double q) const;
  std::int64_t max_ns() const { return max_ns_.load(std::memory_order_relaxed); }
  std::uint64_t count() const { return count_.load(std::memory_order_relaxed); }

  // Bucket layout, for tests and reports.
  static std::size_t bucket_of(std::int64_t latency_ns);
  static std::int64_t upper_edge_ns(std::size_t bucket);  // -1 for the open last bucket

 private:
  static constexpr std::size_t kMicroBuckets = 1000;  // [0, 1 ms) by 1 us
  static constexpr std::size_t kTenthBuckets = 90;    // [1 ms, 10 ms) by 100 us
  static constexpr std::size_t kMilliBuckets = 990;   // [10 ms, 1 s) by 1 ms
  static constexpr std::size_t kBuckets = kMicroBuckets + kTenthBuckets + kMilliBuckets + 1;
  std::array<std::atomic<std::uint64_t>, kBuckets> buckets_{};
  std::atomic<std::uint64_t> count_{0};
  std::atomic<std::int64_t> max_ns_{0};
};

}  // namespace rtm::comp
