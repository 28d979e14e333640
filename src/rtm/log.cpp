// SPDX-License-Identifier: Apache-2.0
#include "rtm/log.h"

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "rt/thread.h"

namespace rtm {

namespace {
// What the real-time base warns about (a refused SCHED_FIFO, pinning or mlockall) goes to the
// framework's log in every program linked with the core.
void warn_to_log(const std::string& message) { log().warn("{}", message); }
const bool warnings_routed = (set_warning_sink(&warn_to_log), true);
}  // namespace

spdlog::logger& log() {
  // Not registered in spdlog's global registry, so no other library's settings touch it.
  static const std::shared_ptr<spdlog::logger> logger = [] {
    auto l = std::make_shared<spdlog::logger>("rtm", std::make_shared<spdlog::sinks::stderr_color_sink_mt>());
    l->set_pattern("[%H:%M:%S.%e] [rtm] [%^%l%$] %v");
    return l;
  }();
  return *logger;
}

}  // namespace rtm
