// SPDX-License-Identifier: Apache-2.0
// RigServer: a Pa10Rig answering on a CAN bus from a thread of its own, in lock-step (each
// SYNC advances the plant one SYNC period, then is answered), as `pa10-sim --lockstep` does.
// Heartbeats also go out every 100 ms of wall time, so a master that watches heartbeats in
// real time is served while no SYNC flows. The CAN master's tests and benchmarks run it on a
// KinematicPlant.
//
// Other threads reach the rig only through with_rig(), which holds the serving thread off.
#pragma once

#include <atomic>
#include <memory>
#include <mutex>
#include <thread>

#include "arm/can/bus.h"
#include "sim/bus_sink.h"
#include "sim/pa10_rig.h"

namespace rtm::sim {

class RigServer {
 public:
  // Serves `rig` (which must outlive the server) on `bus`; with a `sensor_bus`, the force
  // sensors are on that one (Pa10Rig::set_sensor_sink). Nothing happens before start().
  RigServer(Pa10Rig& rig, std::unique_ptr<rtm::can::Bus> bus,
            std::unique_ptr<rtm::can::Bus> sensor_bus = nullptr);
  ~RigServer();  // stop()
  RigServer(const RigServer&) = delete;
  RigServer& operator=(const RigServer&) = delete;

  // Powers the rig on (the nodes' boot-up messages) and serves until stop(). Configure the
  // devices (a disconnected node never boots) with with_rig() before it.
  void start();
  // Ends the serving thread; idempotent. A bus that goes away ends it too.
  void stop();

  // Runs f(rig, out) with the serving thread held off; `out` is the drive bus, for frames a
  // fault injection sends (Pa10Rig::sensor_sink(out) is the sensors').
  // What f sent leaves when it returns.
  template <class F>
  decltype(auto) with_rig(F&& f) {
    std::lock_guard lock(mutex_);
    struct FlushAfter {
      RigServer& server;
      ~FlushAfter() { server.flush_sinks_quietly(); }
    } flush_after{*this};
    return f(rig_, static_cast<FrameSink&>(sink_));
  }

 private:
  void run();
  bool serve_pending();  // false when a bus went away
  void flush_sinks();          // the sinks keep frames until this (BusSink); throws BusError
  void flush_sinks_quietly();  // the same; a bus that went away is found by the serving thread

  Pa10Rig& rig_;
  std::unique_ptr<rtm::can::Bus> bus_;
  std::unique_ptr<rtm::can::Bus> sensor_bus_;
  BusSink sink_;
  std::unique_ptr<BusSink> sensor_sink_;
  std::mutex mutex_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace rtm::sim
