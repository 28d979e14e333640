// SPDX-License-Identifier: Apache-2.0
// rtm-canhub <socket path>: runs the user-space CAN bus until SIGINT or SIGTERM.
#include <signal.h>

#include <cstdio>
#include <exception>

#include "arm/can/bus.h"
#include "arm/can/local_bus.h"

int main(int argc, char** argv) {
  if (argc != 2 || argv[1][0] == '-') {
    std::fprintf(stderr,
                 "usage: rtm-canhub <socket path>\n"
                 "Runs a user-space CAN bus: every frame an endpoint sends reaches every other\n"
                 "endpoint. Endpoints open the bus spec 'local:<socket path>'.\n");
    return 2;
  }
  // Block the stop signals before the hub thread starts so only sigwait sees them.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
  try {
    rtm::can::LocalHub hub(argv[1]);
    std::printf("rtm-canhub: listening on %s\n", hub.path().c_str());
    std::fflush(stdout);
    int signal_number = 0;
    sigwait(&stop_signals, &signal_number);
    hub.stop();
    const auto c = hub.counters();
    std::printf("rtm-canhub: stopped; %llu frames forwarded, %llu deliveries dropped, %llu malformed\n",
                static_cast<unsigned long long>(c.frames_forwarded),
                static_cast<unsigned long long>(c.deliveries_dropped),
                static_cast<unsigned long long>(c.datagrams_malformed));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rtm-canhub: %s\n", e.what());
    return 1;
  }
  return 0;
}
