// SPDX-License-Identifier: Apache-2.0
// A protocol-level attacker on the PA10 master's bus, for the attack tests and the bench that
// measures how fast the master stops the arm (bench/can/attack_bench.cpp).
#pragma once

#include <atomic>
#include <chrono>
#include <cstring>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "arm/can/bus.h"
#include "arm/can/protocol.h"
#include "rtm_test/eventually.h"

namespace rtm::can::testing {

// Another node on the master's bus. After each of the master's SYNCs it waits `delay` and sends
// `frames(sync_counter)`. A second endpoint watches the bus as candump would, in the order the
// frames crossed it, which gives the figure: how many of the master's SYNCs from the first attack
// frame on until the SYNC that latched a quick stop in drive 1, and whether NMT pre-operational
// followed.
class Attacker {
 public:
  using Frames = std::function<std::vector<can_frame>(std::uint8_t sync_counter)>;
  Attacker(const std::string& spec, Frames frames, std::chrono::microseconds delay = std::chrono::microseconds(150))
      : bus_(open_bus(spec)),
        monitor_bus_(open_bus(spec)),
        frames_(std::move(frames)),
        delay_(delay),
        monitor_([this] { monitor(); }),
        thread_([this] { run(); }) {}
  ~Attacker() { stop(); }
  void stop() {
    stopping_ = true;
    if (thread_.joinable()) thread_.join();
    if (monitor_.joinable()) monitor_.join();
  }
  // Waits until the master latched a quick stop and took drive 1 out of operational, or 10 s.
  bool wait_for_stop() {
    return rtm_test::eventually([this] { return quick_stop_after_ >= 0 && pre_operational_seen_; },
                                std::chrono::seconds(10));
  }
  // The master's SYNCs on the bus from the first attack frame to (and with) the one that
  // latched the quick stop.
  int syncs_until_quick_stop() const { return quick_stop_after_; }
  // Every SYNC on the bus, the master's and the attacker's, from the first attack frame until
  // NMT pre-operational for drive 1: each one steps a lock-step plant by a period.
  int all_syncs_until_pre_operational() const { return all_syncs_; }
  int attacks() const { return attacks_; }

 private:
  void run() {
    can_frame frame{};
    while (!stopping_) {
      if (!bus_->receive(frame, 20) || classify(frame).type != FrameType::sync) continue;
      const std::uint8_t counter = frame.data[0];
      std::this_thread::sleep_for(delay_);
      {
        std::lock_guard lock(sent_mutex_);
        for (const can_frame& f : frames_(counter)) sent_.push_back(f);
        for (const can_frame& f : frames_(counter)) bus_->send(f);
      }
      ++attacks_;
    }
  }
  bool is_attack(const can_frame& frame) {
    std::lock_guard lock(sent_mutex_);
    for (const can_frame& f : sent_)
      if (f.can_id == frame.can_id && f.can_dlc == frame.can_dlc && std::memcmp(f.data, frame.data, f.can_dlc) == 0)
        return true;
    return false;
  }
  void monitor() {
    can_frame frame{};
    bool attacked = false;
    bool quick_stop_pending = false;
    int syncs = 0;
    int last_master_counter = -1;
    while (!stopping_) {
      if (!monitor_bus_->receive(frame, 20)) continue;
      const Classified c = classify(frame);
      if (c.type == FrameType::sync) {
        if (attacked && !pre_operational_seen_) ++all_syncs_;
        // The master's counters follow each other; a repeat (a replayed SYNC) is the attacker's.
        if (frame.data[0] == last_master_counter || is_attack(frame)) {
          if (!attacked) ++all_syncs_;  // the first attack frame is this SYNC
          attacked = true;
          continue;
        }
        last_master_counter = frame.data[0];
        if (!attacked) continue;
        ++syncs;
        if (quick_stop_pending && quick_stop_after_ < 0) quick_stop_after_ = syncs;
        continue;
      }
      if (is_attack(frame)) {
        attacked = true;
        continue;
      }
      if (c.type == FrameType::drive_command && c.node == drive_node(0) && attacked) {
        const auto command = decode_drive_command(frame);
        if (command && command->controlword == controlword::kQuickStop) quick_stop_pending = true;
      }
      if (c.type == FrameType::nmt) {
        const auto nmt = decode_nmt(frame);
        if (nmt && nmt->command == NmtCommand::enter_pre_operational && nmt->node == drive_node(0) && attacked)
          pre_operational_seen_ = true;
      }
    }
  }

  std::unique_ptr<Bus> bus_;
  std::unique_ptr<Bus> monitor_bus_;
  Frames frames_;
  std::chrono::microseconds delay_;
  std::mutex sent_mutex_;
  std::vector<can_frame> sent_;
  std::atomic<bool> stopping_{false};
  std::atomic<int> attacks_{0};
  std::atomic<int> quick_stop_after_{-1};
  std::atomic<bool> pre_operational_seen_{false};
  std::atomic<int> all_syncs_{0};
  std::thread monitor_;
  std::thread thread_;
};

}  // namespace rtm::can::testing
