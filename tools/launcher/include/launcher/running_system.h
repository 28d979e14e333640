// SPDX-License-Identifier: Apache-2.0
// The running system as a system file: what `rtm serve` offers to save and `rtm record` keeps
// in a recording's metadata.
#pragma once

#include "browser/browser.h"
#include "launcher/system_file.h"

#include <array>
#include <string>
#include <string_view>
#include <vector>

namespace rtm::cli {

// A component of the running system left out of it, and why.
struct LeftOut {
  std::string name;
  std::string why;
};

// Owners of the temporary InPorts RTM's own tools subscribe (rtm serve's plots, rtm watch,
// rtm record, rtm play): their subscriptions are a tool's, not the system's wiring.
inline constexpr std::array<std::string_view, 4> kToolSubscriberPrefixes = {"rtm-serve-", "rtm-watch-", "rtm-record-", "rtm-play-"};
bool is_tool_subscriber(std::string_view peer);

// Whether a name follows the naming rule (rtm/naming.h's check_name): a component `rtm up`
// could have started under it.
bool follows_naming_rule(const std::string& name);

// The running system as a system file `rtm up` accepts: this host's components with the
// commands that started them and the values of their parameters that may change while they
// run (a fixed one is in the command), every subscription, and those on. A component whose command
// cannot be read from here (another host, another user's process) is left out, with why.
// Components that cannot be put in it are in left_out, with why.
SystemFile running_system(const Browser& browser, const std::string& name, std::vector<LeftOut>& left_out);

}  // namespace rtm::cli
