// SPDX-License-Identifier: Apache-2.0
// A component as an executable and as a loadable module, from one source.
//
//   namespace {
//   rtm::ComponentMain controller() {
//     auto params = std::make_shared<ControllerParams>();   // one per instance
//     return {.kind = "controller",
//             .add_options = [params](CLI::App& app) { ... *params ... },
//             .create = [params](const rtm::RunSettings& s) { return std::make_unique<Controller>(s.name, *params); }};
//   }
//   }  // namespace
//   RTM_COMPONENT(controller)
//
// RTM_COMPONENT defines both the program's main() (run_component with a ComponentMain of its
// own) and the module's entry rtm-container looks up; CMake's rtm_add_component
// (cmake/RtmComponent.cmake) compiles the source once and links it as both. Each member the
// container loads from a module gets a ComponentMain of its own, so the make function keeps
// per-instance state in what its lambdas hold by value (a shared_ptr), never in a static.
//
// Modules are found by the program's name: rtm-controller is rtm-controller.so in
// $RTM_MODULE_PATH (folders separated by ':'), beside a program given with a path
// (<its folder>/../lib/rtm/modules), then in <rtm-container's folder>/../lib/rtm/modules.
#pragma once

#include "host/runner.h"

#include <cstdint>
#include <string>

namespace rtm {

// Changes when ComponentMain or RunSettings change shape: a module built against another
// runner is refused by name instead of crashing.
inline constexpr std::uint32_t kComponentModuleAbi =
    (1u << 24) | static_cast<std::uint32_t>((sizeof(ComponentMain) << 12) ^ sizeof(RunSettings));

struct ComponentModule {
  std::uint32_t abi;
  ComponentMain (*make)();
};

// The module of `program` (a name, a program's path, or a module's path ending in .so), loaded
// once and kept loaded. Throws std::runtime_error saying every place it looked, or why the
// file found is no component module.
const ComponentModule& load_component_module(const std::string& program);

// rtm-container's main(): several components in one process (docs/system-files.md).
int run_container(int argc, char** argv);

}  // namespace rtm

#define RTM_COMPONENT_MODULE_SYMBOL "rtm_component_module"

#define RTM_COMPONENT(make_main)                                                               \
  extern "C" __attribute__((visibility("default"))) const ::rtm::ComponentModule*              \
  rtm_component_module() {                                                                     \
    static const ::rtm::ComponentModule module{::rtm::kComponentModuleAbi, &make_main};        \
    return &module;                                                                            \
  }                                                                                            \
  int main(int argc, char** argv) { return ::rtm::run_component(argc, argv, make_main()); }
