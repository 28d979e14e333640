// SPDX-License-Identifier: Apache-2.0
// The framework's one logger.
#pragma once

#include <spdlog/logger.h>

namespace rtm {

// The "rtm" logger (stderr, colour when a terminal). Created on first use; thread-safe.
// Periodic paths never log: they count, and the counters are read through RTMExt.idl.
spdlog::logger& log();

}  // namespace rtm
