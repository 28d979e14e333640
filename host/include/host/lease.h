// SPDX-License-Identifier: Apache-2.0
// Composites' holds on their members (RtComponentEx::hold/release), both sides:
//   Leases        the member's: each holder renews its hold within its lease; a hold not
//                 renewed in time ends, and `expired` is called (the component turns itself
//                 off). The runner gives one to each component it hosts
//                 (ComponentServant::keep_holds).
//   HoldRenewal   the composite's: renews its holds on its members every lease/5 while it
//                 lives, and releases them at the end. A composite whose process dies stops
//                 renewing, and its members turn themselves off within the lease instead of
//                 running on, wired and out of anyone's reach.
// Each side's thread runs only while there are holds; the renewal's makes remote calls, so it
// is never the one that ends holds.
#pragma once

#include "rtm/component.h"

#include <RTMExt.hh>

#include <atomic>
#include <vector>

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

class HoldRenewal final {
 public:
  // Holds each target for holder (lease_ms, 50..60000 ms) at once and every lease_ms/5 after,
  // on a thread of its own. A target that raises is logged once, when it starts to, and tried
  // again at the next renewal. A plain RtComponent (nil after narrowing) cannot be held.
  HoldRenewal(std::string holder, std::vector<RTM::RtComponentEx_var> targets, std::uint32_t lease_ms);
  ~HoldRenewal();  // stops renewing and releases every target (errors ignored)
  HoldRenewal(const HoldRenewal&) = delete;
  HoldRenewal& operator=(const HoldRenewal&) = delete;

  // Rounds of renewal done (each target asked once per round).
  std::uint64_t rounds() const { return rounds_.load(); }

 private:
  void run();

  const std::string holder_;
  const std::vector<RTM::RtComponentEx_var> targets_;
  const std::uint32_t lease_ms_;
  std::atomic<std::uint64_t> rounds_{0};
  std::mutex mutex_;
  std::condition_variable stop_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace rtm
