#include "rtm/log.h"

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

namespace rtm {

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
