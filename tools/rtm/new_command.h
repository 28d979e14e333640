// SPDX-License-Identifier: Apache-2.0
// rtm new component NAME: the skeleton of a component project outside this tree (scaffold.h).
#pragma once

#include "scaffold/scaffold.h"

#include <CLI/App.hpp>

#include <string>
#include <vector>

namespace rtm::cli {

struct NewCommand {
  CLI::App* component = nullptr;
  std::string name;
  std::vector<std::string> in, out;  // "name:Type"
  std::vector<std::string> params;   // "name:unit:default[:description]"
  std::string period = "2ms";
  std::string description;
  std::vector<std::string> idl;            // IDL files of the ports' own types
  std::vector<std::string> type_packages;  // packages of such types
  bool python = false;                      // --python: a component in Python
  std::string parent = ".";

  // Adds `new` and its subcommand `component` to app.
  void add_to(CLI::App& app);
  bool parsed() const;
  // Writes the project and says what it wrote and how to build it. Throws
  // std::invalid_argument (bad input) or std::runtime_error (an existing folder, a failed write).
  void run(bool json) const;
};

}  // namespace rtm::cli
