// SPDX-License-Identifier: Apache-2.0
// rtm replay: a component's logic run again against its cycle log (host/cycle_log.h), on
// logical time, its outputs compared with the logged ones byte for byte.
#pragma once

#include <CLI/App.hpp>

#include <cstddef>
#include <string>
#include <vector>

namespace rtm::cli {

struct ReplayCommand {
  CLI::App* app = nullptr;
  std::string program;  // rtm-controller, a program's path, or a module (.so)
  std::string log;
  std::string output;
  std::vector<std::string> set;             // NAME=VALUE, after the logged parameters
  std::vector<std::string> component_args;  // after --: the component's own options
  std::size_t show = 5;

  void add_to(CLI::App& parent);
  bool parsed() const { return app != nullptr && app->parsed(); }
  // Needs no naming service. Prints what was replayed, how fast, and where and by how much the
  // outputs differ (or JSON). Returns 0 when every output is identical, 1 otherwise.
  int run(bool json) const;
};

}  // namespace rtm::cli
