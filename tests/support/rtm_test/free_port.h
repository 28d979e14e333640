// SPDX-License-Identifier: Apache-2.0
// Free TCP ports on the loopback interface, so tests never use a fixed port.
#pragma once

#include <chrono>
#include <cstdint>

namespace rtm_test {

// A TCP port on 127.0.0.1 that nothing listens on right now (the kernel's choice). Another
// process may take it before it is used; callers that start a server retry on failure.
std::uint16_t free_loopback_port();

// True once something accepts TCP connections on 127.0.0.1:port.
bool loopback_port_accepts(std::uint16_t port);

}  // namespace rtm_test
