// SPDX-License-Identifier: Apache-2.0
// rtm tls init|issue: a system's certificate authority and the TLS folders of its hosts (host/tls.h).
#pragma once

#include <CLI/App.hpp>

#include <string>

namespace rtm::cli {

struct TlsCommand {
  CLI::App* init = nullptr;
  CLI::App* issue = nullptr;
  std::string folder;         // init: the folder to make; issue: the authority's folder
  std::string new_folder;     // issue: the folder to make for another host
  std::string system = "rtm";
  std::string name;           // the identity's common name
  int days = 3650;

  // Adds `tls` and its two subcommands to app.
  void add_to(CLI::App& app);
  bool parsed() const;
  // Makes the folder; prints what it made (one line per file) or JSON. Throws
  // std::runtime_error / std::invalid_argument with the file and the reason.
  void run(bool json) const;
};

}  // namespace rtm::cli
