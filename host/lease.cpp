// SPDX-License-Identifier: Apache-2.0
#include "host/lease.h"

#include "rtm/log.h"

#include <stdexcept>
#include <vector>

namespace rtm {

namespace {

void check_lease(std::uint32_t lease_ms) {
  if (lease_ms < Leases::kMinLeaseMs || lease_ms > Leases::kMaxLeaseMs)
    throw std::invalid_argument("lease of " + std::to_string(lease_ms) + " ms: want 50..60000 ms");
}

}  // namespace

Leases::Leases(std::function<void(const std::string&, std::uint32_t)> expired) : expired_(std::move(expired)) {}

Leases::~Leases() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    holds_.clear();
  }
  changed_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void Leases::hold(const std::string& holder, std::uint32_t lease_ms) {
  check_lease(lease_ms);
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return;
    holds_[holder] = Hold{std::chrono::steady_clock::now() + std::chrono::milliseconds(lease_ms), lease_ms};
    if (!thread_.joinable()) thread_ = std::thread([this] { run(); });
  }
  changed_.notify_all();
}

void Leases::release(const std::string& holder) {
  {
    std::lock_guard lock(mutex_);
    holds_.erase(holder);
  }
  changed_.notify_all();
}

void Leases::run() {
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    if (holds_.empty()) {
      changed_.wait(lock);
      continue;
    }
    auto next = holds_.begin()->second.until;
    for (const auto& [holder, h] : holds_) next = std::min(next, h.until);
    changed_.wait_until(lock, next);
    const auto now = std::chrono::steady_clock::now();
    std::vector<std::pair<std::string, std::uint32_t>> ended;
    for (auto it = holds_.begin(); it != holds_.end();) {
      if (it->second.until <= now) {
        ended.emplace_back(it->first, it->second.lease_ms);
        it = holds_.erase(it);
      } else {
        ++it;
      }
    }
    if (ended.empty() || stopping_) continue;
    lock.unlock();
    for (const auto& [holder, lease_ms] : ended) expired_(holder, lease_ms);
    lock.lock();
  }
}

HoldRenewal::HoldRenewal(std::string holder, std::vector<RTM::RtComponentEx_var> targets, std::uint32_t lease_ms)
    : holder_(std::move(holder)), targets_(std::move(targets)), lease_ms_(lease_ms) {
  check_lease(lease_ms_);
  thread_ = std::thread([this] { run(); });
}

HoldRenewal::~HoldRenewal() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  stop_.notify_all();
  thread_.join();
  for (const auto& target : targets_) {
    try {
      target->release(holder_.c_str());
    } catch (const CORBA::Exception&) {
      // Gone or unreachable: its lease ends the hold.
    }
  }
}

void HoldRenewal::run() {
  std::vector<bool> failing(targets_.size(), false);
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    lock.unlock();
    for (std::size_t i = 0; i < targets_.size(); ++i) {
      try {
        targets_[i]->hold(holder_.c_str(), lease_ms_);
        failing[i] = false;
      } catch (const CORBA::Exception& e) {
        if (!failing[i]) log().warn("{}: renewing its hold on a member raised {}", holder_, e._name());
        failing[i] = true;
      }
    }
    rounds_.fetch_add(1);
    lock.lock();
    stop_.wait_for(lock, std::chrono::milliseconds(lease_ms_ / 5), [this] { return stopping_; });
  }
}

}  // namespace rtm
