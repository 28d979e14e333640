// SPDX-License-Identifier: Apache-2.0
// What `rtm ls` and `rtm cat` print: the browser's results as text for people and as JSON
// for scripts. Everything a component says of itself (ports with their elements and units,
// statistics, parameters) is shown as it says it; the tool knows no component kind.
#pragma once

#include "browser.h"

#include <nlohmann/json.hpp>

#include <string>
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

// A statistic's value as text: a count without decimals, else 3 significant decimals.
std::string format_statistic(double value);

}  // namespace rtm::cli
