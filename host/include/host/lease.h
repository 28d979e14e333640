// SPDX-License-Identifier: Apache-2.0
// Holds on a component by composites (RtComponentEx::hold/release): each holder renews its
// hold within its lease; a hold not renewed in time ends, and `expired` is called (the
// component turns itself off). A thread of its own runs only while there are holds. The
// runner gives one to each component it hosts (ComponentServant::keep_holds).
#pragma once

#include "rtm/component.h"

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <thread>

namespace rtm {

class Leases final : public HoldKeeper {
 public:
  // expired(holder, lease_ms): called on the leases' thread, no lock held.
  explicit Leases(std::function<void(const std::string&, std::uint32_t)> expired);
  ~Leases() override;  // ends every hold without calling expired
  Leases(const Leases&) = delete;
  Leases& operator=(const Leases&) = delete;

  static constexpr std::uint32_t kMinLeaseMs = 50;
  static constexpr std::uint32_t kMaxLeaseMs = 60'000;
  // Starts or renews holder's hold for lease_ms. std::invalid_argument outside 50..60000 ms.
  void hold(const std::string& holder, std::uint32_t lease_ms) override;
  void release(const std::string& holder) override;

 private:
  struct Hold {
    std::chrono::steady_clock::time_point until;
    std::uint32_t lease_ms;
  };
  void run();

  std::function<void(const std::string&, std::uint32_t)> expired_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::map<std::string, Hold> holds_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace rtm
