// SPDX-License-Identifier: Apache-2.0
// rtm play: a recording's data put into InPorts at the recorded pace (recorder/player.h).
#pragma once

#include <CLI/App.hpp>

#include <atomic>

#include "browser/browser.h"
#include "recorder/player.h"

namespace rtm::cli {

struct PlayCommand {
  CLI::App* app = nullptr;
  PlayOptions options;

  void add_to(CLI::App& parent);
  bool parsed() const { return app != nullptr && app->parsed(); }
  // Plays; prints what each route put and how late (or JSON). Returns 0, or 1 when a put failed.
  int run(const Browser& browser, bool json, const std::atomic<bool>& interrupted) const;
};

}  // namespace rtm::cli
