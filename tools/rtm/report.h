// SPDX-License-Identifier: Apache-2.0
// What `rtm ls` and `rtm cat` print: the browser's results as text for people (the JSON for
// scripts is browser/json.h). Everything a component says of itself (ports with their elements and units,
// statistics, parameters) is shown as it says it; the tool knows no component kind.
#pragma once

#include "browser/browser.h"
#include "browser/json.h"

#include <string>
#include <string_view>
#include <vector>

namespace rtm::cli {

void print_ls(const std::vector<ComponentInfo>& components, bool detailed);
void print_cat(const ComponentInfo& component);

// Text a component or the naming service gave (a name, a unit, an error) as a terminal shows
// it safely on one line: control characters (C0, DEL, C1: U+009B is a terminal's CSI), line
// separators, bytes that are no UTF-8 and the backslash itself are written as escapes (\n,
// \x1b, \xc2\x9b, \\). Valid UTF-8 text without them is unchanged.
std::string terminal_text(std::string_view text);
// A component's or host's name for the terminal: as it is when it follows the naming rule, else
// escaped and marked " (not a valid name)": someone bound it by hand, not an RTM component.
std::string shown_name(std::string_view name);

// A statistic's value as text: a count without decimals, else 3 significant decimals.
std::string format_statistic(double value);

}  // namespace rtm::cli
