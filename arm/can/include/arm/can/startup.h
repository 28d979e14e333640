// SPDX-License-Identifier: Apache-2.0
// The PA10 master's start-up sequence, run once on a BusCycle before any periodic cycle:
//   1. every drive and configured sensor alive (boot-up or heartbeat) within boot_timeout_ns;
//   2. NMT enter pre-operational; per drive SDO 0x6060:00 = 9 (cyclic synchronous velocity)
//      and 0x6061:00 read back as 9;
//   3. NMT start all;
//   4. cycles paced at the SYNC period until every drive reports operation enabled (shutdown
//      -> switch on -> enable operation, each on the drive's own statusword) within
//      enable_timeout_ns.
// Throws std::runtime_error naming the bus, the node and the step that failed.
#pragma once

#include "arm/can/bus_cycle.h"

namespace rtm::can {

void run_startup(BusCycle& cycle);

}  // namespace rtm::can
