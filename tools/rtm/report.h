// SPDX-License-Identifier: Apache-2.0
// What `rtm ls` and `rtm cat` print: the browser's results as text for people and as JSON
// for scripts. Everything a component says of itself (ports with their elements and units,
// statistics, parameters) is shown as it says it; the tool knows no component kind.
#pragma once

#include "browser.h"

#include <nlohmann/json.hpp>

#include <string>
#include <string_view>
#include <vector>

namespace rtm::cli {

// One line for a failed remote call: the exception's name, or what a refusal by access control
// means and what to do about it.
std::string failure_text(const CORBA::Exception& e);

nlohmann::json port_json(const PortInfo& port);
nlohmann::json timing_json(const RTM::TimingStats& timing);
// detailed: timing, statistics and parameters too (`rtm cat`, `rtm ls -l`).
nlohmann::json component_json(const ComponentInfo& component, bool detailed);

void print_ls(const std::vector<ComponentInfo>& components, bool detailed);
void print_cat(const ComponentInfo& component);

// Text a component or the naming service gave (a name, a unit, an error) as a terminal shows
// it safely on one line: control characters (C0, DEL, C1: U+009B is a terminal's CSI), line
// separators, bytes that are no UTF-8 and the backslash itself are written as escapes (\n,
// \x1b, \xc2\x9b, \\). Valid UTF-8 text without them is unchanged.
std::string terminal_text(std::string_view text);
// Whether a name follows the naming rule (rtm::check_name).
bool name_follows_rule(std::string_view name);
// A component's or host's name for the terminal: as it is when it follows the naming rule, else
// escaped and marked " (not a valid name)": someone bound it by hand, not an RTM component.
std::string shown_name(std::string_view name);

// A statistic's value as text: a count without decimals, else 3 significant decimals.
std::string format_statistic(double value);

}  // namespace rtm::cli
