// SPDX-License-Identifier: Apache-2.0
// Which CAN buses a program of the arm talks on, with their command-line options: declared
// here once for the components, the arm's hardware and the simulator.
#pragma once

#include <string>

namespace CLI {
class App;
}

namespace rtm::can {

// The bus a component looks for when none is named: the local bus pa10-sim serves by default.
inline constexpr const char* kDefaultBus = "local:/tmp/rtm-pa10.bus";

struct BusOptions {
  std::string bus = kDefaultBus;  // the arm's bus: "local:<path>" or "socketcan:<if>"
  std::string sensor_bus;         // the force sensors' own bus; "" = they are on `bus`

  // The bus the force sensors are on.
  const std::string& sensors() const { return sensor_bus.empty() ? bus : sensor_bus; }

  // --bus and --sensor-bus on app, bound to these fields.
  void add_options(CLI::App& app);
};

}  // namespace rtm::can
