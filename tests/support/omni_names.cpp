// SPDX-License-Identifier: Apache-2.0
#include "rtm_test/omni_names.h"

#include "rtm_test/eventually.h"
#include "rtm_test/free_port.h"

#include <fmt/format.h>
#include <stdlib.h>

#include <stdexcept>
#include <system_error>
#include <thread>

namespace rtm_test {

namespace {

std::filesystem::path make_temp_dir() {
  auto pattern = (std::filesystem::temp_directory_path() / "rtm-omninames-XXXXXX").string();
  if (::mkdtemp(pattern.data()) == nullptr) {
    throw std::runtime_error(fmt::format("OmniNames: cannot create a directory like {}", pattern));
  }
  return pattern;
}

}  // namespace

OmniNames::OmniNames() : port_(free_loopback_port()), log_dir_(make_temp_dir()) {
  try {
    start(Data::fresh);
  } catch (...) {
    std::error_code ignored;
    std::filesystem::remove_all(log_dir_, ignored);
    throw;
  }
}

OmniNames::~OmniNames() {
  stop();
  std::error_code ignored;
  std::filesystem::remove_all(log_dir_, ignored);
}

std::string OmniNames::address() const { return fmt::format("127.0.0.1:{}", port_); }

void OmniNames::stop() { process_.reset(); }

void OmniNames::start(Data data) {
  if (process_) throw std::logic_error("OmniNames::start: already running");
  if (data == Data::fresh) {
    for (const auto& entry : std::filesystem::directory_iterator(log_dir_)) {
      std::filesystem::remove_all(entry.path());
    }
  }
  // -ignoreport plus an explicit endpoint keeps it on loopback only.
  std::vector<std::string> argv{"omniNames"};
  if (data == Data::fresh) argv.insert(argv.end(), {"-start", std::to_string(port_)});
  argv.insert(argv.end(), {"-logdir", log_dir_.string(), "-ignoreport", "-ORBendPoint",
                           fmt::format("giop:tcp:127.0.0.1:{}", port_)});

  // The port of a just-stopped service can stay busy for a moment: retry a few times.
  std::string last_output;
  for (int attempt = 0; attempt < 20; ++attempt) {
    auto process = std::make_unique<ChildProcess>(argv, ChildProcess::Options{{}, std::chrono::milliseconds(3000), false});
    try {
      process->wait_for_line("Root context is", std::chrono::seconds(10));
      eventually([&] { return loopback_port_accepts(port_); }, std::chrono::seconds(5));
      if (loopback_port_accepts(port_) && process->running()) {
        process_ = std::move(process);
        return;
      }
      last_output = process->output();
    } catch (const std::runtime_error& ex) {
      last_output = ex.what();
    }
    process.reset();
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  throw std::runtime_error(fmt::format("omniNames did not come up on {}: {}", address(), last_output));
}

void OmniNames::restart(Data data) {
  stop();
  start(data);
}

}  // namespace rtm_test
