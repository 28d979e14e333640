// SPDX-License-Identifier: Apache-2.0
// What rtm serve's event streams send: the system, polled on one thread every period while at
// least one page is connected, whatever the number of pages; each stream waits for a version
// it has not sent.
//
// The system's timing changes on every look, so a stream that polled and sent whenever the
// answer differed would poll without pause: one page open cost the components it watched more
// CPU than their own loops. Here the components are asked at most once per period.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

namespace rtm::cli {

class SystemFeed {
 public:
  // poll() returns the system as the streams send it; it is called with no lock held.
  SystemFeed(std::function<std::string()> poll, std::chrono::milliseconds period);
  ~SystemFeed();
  SystemFeed(const SystemFeed&) = delete;
  SystemFeed& operator=(const SystemFeed&) = delete;

  struct Update {
    std::string text;
  };

  // One connected page. While one exists the feed polls; the first update a subscription gets
  // is polled after it subscribed (never a view left from an earlier page).
  class Subscription {
   public:
    explicit Subscription(SystemFeed& feed);
    ~Subscription();
    Subscription(const Subscription&) = delete;
    Subscription& operator=(const Subscription&) = delete;
    // The next version this subscription has not had, waiting up to timeout; nullopt on timeout
    // or when the feed stops.
    std::optional<Update> next(std::chrono::milliseconds timeout);

   private:
    SystemFeed& feed_;
    std::uint64_t seen_;
  };

  // Wakes every waiting subscription (they get nullopt) and ends the polling thread.
  void stop();
  bool stopped() const;
  // How many times poll() has been called.
  std::uint64_t polls() const;

 private:
  void run();

  std::function<std::string()> poll_;
  std::chrono::milliseconds period_;
  mutable std::mutex mu_;
  std::condition_variable changed_;   // a new version, or stopping
  std::condition_variable wanted_;    // a subscriber came, or stopping
  int subscribers_ = 0;
  bool stopping_ = false;
  bool poll_now_ = false;           // a first page came: poll without waiting out the period
  std::uint64_t stale_upto_ = 0;    // versions polled before the first page came
  std::uint64_t version_ = 0;
  std::uint64_t polls_ = 0;
  std::string text_;
  std::thread thread_;
};

}  // namespace rtm::cli
