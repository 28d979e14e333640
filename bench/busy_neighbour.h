// SPDX-License-Identifier: Apache-2.0
// Another program on the machine, for the benches that compare quiet with loaded: a process
// that keeps one CPU busy (a spinning loop at normal priority) until the object goes.
#pragma once

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdint>

namespace rtm_bench {

class BusyNeighbour {
 public:
  BusyNeighbour() {
    pid_ = fork();
    if (pid_ == 0) {
      volatile std::uint64_t spin = 0;
      for (;;) spin = spin + 1;
    }
  }
  ~BusyNeighbour() {
    if (pid_ <= 0) return;
    kill(pid_, SIGKILL);
    waitpid(pid_, nullptr, 0);
  }
  BusyNeighbour(const BusyNeighbour&) = delete;
  BusyNeighbour& operator=(const BusyNeighbour&) = delete;

 private:
  pid_t pid_ = -1;
};

}  // namespace rtm_bench
