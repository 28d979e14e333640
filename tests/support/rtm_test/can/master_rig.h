// SPDX-License-Identifier: Apache-2.0
// A Pa10Master and the emulated PA10 nodes on one local hub, with timeouts that bound how long
// a broken build waits: what the master's tests and the passive listeners' tests start from.
#pragma once

#include <memory>
#include <string>

#include "arm/can/local_bus.h"
#include "arm/can/master.h"
#include "rtm_test/can/emulated_pa10.h"
#include "rtm_test/can/test_paths.h"

namespace rtm::can::testing {

// Timeouts here bound how long a broken build waits; no assertion is about speed. The
// heartbeat timeout is long so a loaded machine cannot fake a heartbeat loss, except in the
// test of heartbeat loss.
inline MasterConfig test_config() {
  MasterConfig c;
  c.boot_timeout_ns = 5'000'000'000;
  c.sdo_timeout_ns = 2'000'000'000;
  c.enable_timeout_ns = 5'000'000'000;
  c.heartbeat_timeout_ns = 5'000'000'000;
  c.step_timeout_ns = 2'000'000'000;
  // A loaded machine can stall the emulated nodes for longer than a few periodic cycles.
  c.missed_feedback_limit = 1000;
  return c;
}

struct Rig {
  TempDir dir;
  LocalHub hub{dir.file("bus")};
  std::string spec = "local:" + dir.file("bus");
  std::unique_ptr<EmulatedPa10> nodes;
  std::unique_ptr<Pa10Master> master;

  explicit Rig(EmulatedPa10::Options options = {}, MasterConfig config = test_config()) {
    // The master connects first so it sees the nodes' boot-up messages.
    master = std::make_unique<Pa10Master>(open_bus(spec), nullptr, config);
    nodes = std::make_unique<EmulatedPa10>(spec, options);
  }
  ~Rig() {
    master.reset();  // before the nodes, so its shutdown frames have a reader
    nodes.reset();
  }
};

}  // namespace rtm::can::testing
