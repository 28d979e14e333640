// SPDX-License-Identifier: Apache-2.0
#include "arm/can/bus_options.h"

#include <CLI/CLI.hpp>

namespace rtm::can {

void BusOptions::add_options(CLI::App& app) {
  app.add_option("--bus", bus, "the arm's CAN bus: local:<path> or socketcan:<if>")->capture_default_str();
  app.add_option("--sensor-bus", sensor_bus, "separate bus of the force sensors (default: --bus)");
}

}  // namespace rtm::can
