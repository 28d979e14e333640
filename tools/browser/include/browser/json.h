// SPDX-License-Identifier: Apache-2.0
// The browser's results as JSON (`rtm ls --json`, `rtm cat --json`, rtm serve's API) and a
// failed remote call as one line of text: what every front end says the same way.
#pragma once

#include "browser/browser.h"

#include <nlohmann/json.hpp>

#include <string>
#include <string_view>

namespace rtm::cli {

// One line for a failed remote call: the exception's name, or what a refusal by access control
// means and what to do about it.
std::string failure_text(const CORBA::Exception& e);

nlohmann::json port_json(const PortInfo& port);
nlohmann::json timing_json(const RTM::TimingStats& timing);
// "count", "warn" or "brake": a contract's on_miss as the system file and --on-miss write it.
const char* miss_action_text(RTM::MissAction action);
// A contract and how it is kept: "contract" of `rtm ls -l --json` and `rtm cat --json`.
nlohmann::json contract_json(const RTM::ContractStatus& contract);
// detailed: timing, statistics and parameters too (`rtm cat`, `rtm ls -l`).
nlohmann::json component_json(const ComponentInfo& component, bool detailed);

// Whether a name follows the naming rule (rtm::check_name).
bool name_follows_rule(std::string_view name);

}  // namespace rtm::cli
