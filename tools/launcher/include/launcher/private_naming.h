// SPDX-License-Identifier: Apache-2.0
// `rtm names`: a naming service of the user's own, on loopback, started once and reused.
//
// omniNames on a free 127.0.0.1 port (loopback only: `-ignoreport` and one endpoint), detached,
// its data and log in SystemState::directory()/names, and a state file there with its address,
// pid and start time. While that process runs, private_naming_up() returns it; when it is gone
// (a reboot, a kill), the next call starts a fresh one on a new port. private_naming_down()
// stops it (SIGTERM, SIGKILL after a grace period) and removes its data.
#pragma once

#include "launcher/launcher.h"
#include "rtm/naming.h"

#include <chrono>
#include <filesystem>
#include <optional>

namespace rtm::cli {

struct PrivateNaming {
  NamingAddress address;
  LaunchedProcess process;  // omniNames, its log
  bool started = false;     // by this call; else it was running already
};

// The running service, or a new one. Throws std::runtime_error saying why omniNames did not
// come up (not found, its log's last lines) after a few ports were tried.
PrivateNaming private_naming_up(std::chrono::milliseconds timeout = std::chrono::seconds(10));

// The service recorded as this user's, while its process runs.
std::optional<PrivateNaming> private_naming_running();

// Stops it and removes its data; what was stopped, nullopt when none ran.
std::optional<PrivateNaming> private_naming_down(std::chrono::milliseconds grace = std::chrono::seconds(5));

}  // namespace rtm::cli
