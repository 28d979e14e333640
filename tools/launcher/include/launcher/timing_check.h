// SPDX-License-Identifier: Apache-2.0
// A system file's timing, checked before anything starts (`rtm check FILE`, and `rtm up` when the
// file declares a contract or a chain): each component's contract as its program declares it
// with the file's options (PROGRAM ARGS... --name NAME --print-contract), then the analysis of
// rt/contract.h over them and the file's chains. docs/timing.md has the model.
#pragma once

#include "launcher/launcher.h"
#include "launcher/system_file.h"
#include "rt/contract.h"

#include <optional>
#include <string>
#include <vector>

namespace rtm::cli {

struct TimingCheck {
  std::vector<TimingContract> contracts;  // of the components whose program declared one, in the file's order
  TimingAnalysis analysis;                // includes a warning for each program that declared none
  std::vector<std::string> without_loop;  // components that run no loop of their own (a composite)
};

// Runs each component's program with --print-contract (at most 5 s each; nothing else starts),
// then analyses the contracts on machine. Throws SystemFileError for a program not found.
TimingCheck check_timing(const SystemFile& file, const MachineLimits& machine = machine_limits(),
                         const ProgramFinder& find = find_program);

// One line of --print-contract's output as a contract; nullopt for a component that runs no loop
// of its own ("contract": null); SystemFileError naming the component and what is wrong when it
// is neither.
std::optional<TimingContract> parse_contract_json(const std::string& line, const std::string& component);

// The analysis as JSON (`rtm check --json`, and the profile of a running system): the
// contracts, the CPUs, the responses, the chains hop by hop and the findings.
std::string timing_check_json(const TimingCheck& check);

}  // namespace rtm::cli
