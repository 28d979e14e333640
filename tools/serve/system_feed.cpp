// SPDX-License-Identifier: Apache-2.0
#include "serve/system_feed.h"

#include <algorithm>

namespace rtm::cli {

SystemFeed::SystemFeed(std::function<std::string()> poll, std::chrono::milliseconds period)
    : poll_(std::move(poll)), period_(period), thread_([this] { run(); }) {}

SystemFeed::~SystemFeed() { stop(); }

void SystemFeed::stop() {
  {
    std::lock_guard lock(mu_);
    stopping_ = true;
  }
  changed_.notify_all();
  wanted_.notify_all();
  if (thread_.joinable() && thread_.get_id() != std::this_thread::get_id()) thread_.join();
}

bool SystemFeed::stopped() const {
  std::lock_guard lock(mu_);
  return stopping_;
}

std::uint64_t SystemFeed::polls() const {
  std::lock_guard lock(mu_);
  return polls_;
}

void SystemFeed::run() {
  std::unique_lock lock(mu_);
  for (;;) {
    wanted_.wait(lock, [this] { return stopping_ || subscribers_ > 0; });
    if (stopping_) return;
    const auto started = std::chrono::steady_clock::now();
    poll_now_ = false;
    lock.unlock();
    std::string now = poll_();  // no lock held across the components' calls
    lock.lock();
    ++polls_;
    // After an idle spell the first poll is a new version even when nothing changed: the
    // page that came waits for one polled after it came.
    if (now != text_ || version_ <= stale_upto_) {
      text_ = std::move(now);
      ++version_;
      changed_.notify_all();
    }
    wanted_.wait_until(lock, started + period_, [this] { return stopping_ || poll_now_; });
  }
}

SystemFeed::Subscription::Subscription(SystemFeed& feed) : feed_(feed) {
  std::lock_guard lock(feed_.mu_);
  if (feed_.subscribers_++ == 0) {
    feed_.stale_upto_ = feed_.version_;
    feed_.poll_now_ = true;
    feed_.wanted_.notify_all();
  }
  // Joining pages already being fed: the latest version is at most a period old; have it now.
  seen_ = std::max(feed_.stale_upto_, feed_.version_ > 0 ? feed_.version_ - 1 : 0);
}

SystemFeed::Subscription::~Subscription() {
  std::lock_guard lock(feed_.mu_);
  --feed_.subscribers_;
}

std::optional<SystemFeed::Update> SystemFeed::Subscription::next(std::chrono::milliseconds timeout) {
  std::unique_lock lock(feed_.mu_);
  if (!feed_.changed_.wait_for(lock, timeout, [this] { return feed_.stopping_ || feed_.version_ > seen_; }))
    return std::nullopt;
  if (feed_.stopping_) return std::nullopt;
  seen_ = feed_.version_;
  return Update{feed_.text_};
}

}  // namespace rtm::cli
