// SPDX-License-Identifier: Apache-2.0
#include "sim/rig_server.h"

#include <poll.h>

#include <algorithm>
#include <chrono>

#include "rt/clock.h"

namespace rtm::sim {

namespace {

constexpr std::int64_t kWallHeartbeatPeriod_ns = 100'000'000;
// How long the thread waits for a frame at most, so stop() is noticed.
constexpr std::int64_t kMaxWait_ns = 5'000'000;

}  // namespace

RigServer::RigServer(Pa10Rig& rig, std::unique_ptr<rtm::can::Bus> bus,
                     std::unique_ptr<rtm::can::Bus> sensor_bus)
    : rig_(rig), bus_(std::move(bus)), sensor_bus_(std::move(sensor_bus)), sink_(*bus_) {
  if (sensor_bus_) sensor_sink_ = std::make_unique<BusSink>(*sensor_bus_);
}

RigServer::~RigServer() { stop(); }

void RigServer::start() {
  std::lock_guard lock(mutex_);
  if (thread_.joinable()) return;
  rig_.set_mode(Pa10Rig::Mode::lock_step);
  rig_.set_sensor_sink(sensor_sink_.get());
  rig_.power_on(sink_);
  flush_sinks_quietly();
  thread_ = std::thread([this] { run(); });
}

void RigServer::flush_sinks() {
  sink_.flush();
  if (sensor_sink_) sensor_sink_->flush();
}

void RigServer::flush_sinks_quietly() {
  try {
    flush_sinks();
  } catch (const rtm::can::BusError&) {
  }
}

void RigServer::stop() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
}

bool RigServer::serve_pending() {
  can_frame frame{};
  try {
    std::lock_guard lock(mutex_);
    while (bus_->receive(frame, 0)) rig_.on_frame(frame, sink_);
    if (sensor_bus_)
      while (sensor_bus_->receive(frame, 0)) rig_.on_sensor_bus_frame(frame);
    flush_sinks();
  } catch (const rtm::can::BusError&) {
    return false;  // the hub went away: whoever owns it is ending
  }
  return true;
}

void RigServer::run() {
  pollfd fds[2] = {{bus_->pollable_fd(), POLLIN, 0},
                   {sensor_bus_ ? sensor_bus_->pollable_fd() : -1, POLLIN, 0}};
  std::int64_t next_beat_ns = monotonic_ns() + kWallHeartbeatPeriod_ns;
  while (!stop_.load()) {
    const std::int64_t wait_ns = std::clamp<std::int64_t>(next_beat_ns - monotonic_ns(), 0, kMaxWait_ns);
    const timespec timeout = to_timespec(wait_ns);
    if (ppoll(fds, 2, &timeout, nullptr) > 0) {
      if (!serve_pending()) return;
      for (const pollfd& fd : fds)
        if (fd.revents & (POLLHUP | POLLERR)) return;  // the hub went away
    }
    const std::int64_t now_ns = monotonic_ns();
    if (now_ns >= next_beat_ns) {
      std::lock_guard lock(mutex_);
      rig_.send_heartbeats(sink_);
      try {
        flush_sinks();
      } catch (const rtm::can::BusError&) {
        return;  // the hub went away
      }
      next_beat_ns = now_ns + kWallHeartbeatPeriod_ns;
    }
  }
}

}  // namespace rtm::sim
