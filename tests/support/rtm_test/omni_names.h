// SPDX-License-Identifier: Apache-2.0
// A real omniNames naming service for one test: on a free loopback port, with its data in a
// temporary directory, stopped (SIGTERM, then SIGKILL) and cleaned up by the destructor.
#pragma once

#include "rtm_test/child_process.h"

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

namespace rtm_test {

class OmniNames {
 public:
  enum class Data { fresh, keep };

  // Starts omniNames and returns once it accepts connections. Throws std::runtime_error with
  // its output when it does not come up.
  OmniNames();
  ~OmniNames();
  OmniNames(const OmniNames&) = delete;
  OmniNames& operator=(const OmniNames&) = delete;

  std::uint16_t port() const { return port_; }
  std::string address() const;  // "127.0.0.1:<port>", the form --naming takes
  bool running() const { return process_ != nullptr; }

  void stop();
  // Starts again on the same port; Data::fresh forgets every binding (a new naming service),
  // Data::keep reloads them from its log.
  void start(Data data = Data::fresh);
  void restart(Data data = Data::fresh);

 private:
  std::uint16_t port_;
  std::filesystem::path log_dir_;
  std::unique_ptr<ChildProcess> process_;
};

}  // namespace rtm_test
