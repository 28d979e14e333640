// SPDX-License-Identifier: Apache-2.0
#include "replay_command.h"

#include "browser/values.h"
#include "host/cycle_log.h"
#include "host/module.h"
#include "rtm/cdr.h"
#include "rtm/log.h"
#include "rtm/orb.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/logger.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>

#include "report.h"

namespace rtm::cli {

using nlohmann::json;

namespace {

// The largest difference of each element between the logged and the replayed outputs of one port.
struct PortDifference {
  std::uint64_t differing = 0;
  const ReplayMismatch* first = nullptr;
  std::vector<std::string> labels;
  std::vector<double> largest;
  std::vector<std::uint64_t> at_cycle;
  std::uint64_t one_sided = 0;  // written on one side only
};

std::map<std::string, PortDifference> differences(const ReplayResult& result) {
  std::map<std::string, PortDifference> out;
  for (const auto& m : result.mismatches) {
    PortDifference& d = out[m.port];
    ++d.differing;
    if (d.first == nullptr) d.first = &m;
    if (m.logged.empty() || m.replayed.empty()) {
      ++d.one_sided;
      continue;
    }
    const auto& tc = result.types.at(m.port);
    const Sample logged = to_sample(from_cdr(tc.in(), m.logged));
    const Sample replayed = to_sample(from_cdr(tc.in(), m.replayed));
    const std::size_t n = std::min(logged.values.size(), replayed.values.size());
    if (d.largest.size() < n) {
      d.largest.resize(n, 0.0);
      d.at_cycle.resize(n, 0);
    }
    for (std::size_t i = 0; i < n; ++i) {
      const double delta = std::abs(replayed.values[i] - logged.values[i]);
      if (delta > d.largest[i] || (std::isnan(delta) && !std::isnan(d.largest[i]))) {
        d.largest[i] = delta;
        d.at_cycle[i] = m.cycle;
      }
    }
    if (d.labels.empty()) {
      const auto names = result.elements.find(m.port);
      if (names != result.elements.end() && names->second.size() == n) d.labels = names->second;
      else d.labels = value_labels(from_cdr(tc.in(), m.logged));
    }
  }
  return out;
}

std::map<std::string, std::string> parameter_settings(const std::vector<std::string>& set) {
  std::map<std::string, std::string> out;
  for (const auto& s : set) {
    const auto eq = s.find('=');
    if (eq == std::string::npos || eq == 0)
      throw std::invalid_argument("--set " + s + ": give NAME=VALUE (e.g. --set gain=\"0.002 0.002 0.002 0 0 0\")");
    out[s.substr(0, eq)] = s.substr(eq + 1);
  }
  return out;
}

}  // namespace

void ReplayCommand::add_to(CLI::App& parent) {
  app = parent.add_subcommand(
      "replay",
      "run a component's logic again against its cycle log (--log-cycles), on logical time, and compare its outputs "
      "with the logged ones");
  app->add_option("program", program, "the component: rtm-controller, a program's path, or a module (.so)")->required();
  app->add_option("log", log, "its cycle log (.mcap), as --log-cycles wrote it")->required();
  app->add_option("component_options", component_args, "after --: the component's own options (e.g. -- --gain ...)");
  app->add_option("-o,--output", output, "write the replayed outputs to this MCAP file");
  app->add_option("--set", set, "NAME=VALUE: a parameter for the replay, after those logged (repeatable)");
  app->add_option("--show", show, "mismatches to list (0: none)")->capture_default_str();
}

namespace {

// The component as the log's program builds it, named as logged, with the options after --;
// replay_options.keep_built gets the parameters those options set.
std::unique_ptr<Component> build(const std::string& program, const std::vector<std::string>& component_args,
                                 const CycleLogInfo& info, ReplayOptions& replay_options) {
  const ComponentMain main = load_component_module(program).make();
  if (!main.kind.empty() && main.kind != info.kind)
    throw std::invalid_argument(fmt::format("{} makes a {}; the log is of a {} ({})", program, main.kind, info.kind,
                                            info.component));
  if (!main.create)
    throw std::invalid_argument(program + " builds its component with the ORB (a composite): replay its members, each "
                                          "from its own log");
  RunSettings settings;
  settings.name = info.component;
  CLI::App options(program);
  if (main.add_options) main.add_options(options);
  try {
    std::vector<std::string> args(component_args.rbegin(), component_args.rend());  // CLI11 takes them reversed
    options.parse(args);
  } catch (const CLI::ParseError& e) {
    throw std::invalid_argument(fmt::format("{}'s options after --: {}", program, e.what()));
  }
  if (main.validate) main.validate(settings);
  auto component = main.create(settings);
  if (component->kind() != info.kind)
    throw std::invalid_argument(fmt::format("{} makes a {}; the log is of a {} ({})", program, component->kind(),
                                            info.kind, info.component));
  for (const CLI::Option* option : options.get_options()) {  // --stale-periods: the parameter stale_periods
    if (option->count() == 0 || option->get_lnames().empty()) continue;
    std::string name = option->get_lnames().front();
    std::replace(name.begin(), name.end(), '-', '_');
    replay_options.keep_built.insert(name);
  }
  return component;
}

double times_real_time(const ReplayResult& result) {
  return result.replay_seconds > 0 ? static_cast<double>(result.logged_span_ns) / 1e9 / result.replay_seconds : 0;
}

void print_json(const ReplayResult& result, const std::map<std::string, PortDifference>& by_port) {
  json ports = json::object();
  for (const auto& [port, d] : by_port) {
    json elements = json::array();
    for (std::size_t i = 0; i < d.largest.size(); ++i)
      elements.push_back({{"element", i < d.labels.size() ? d.labels[i] : std::to_string(i)},
                          {"largest_difference", d.largest[i]},
                          {"at_cycle", d.at_cycle[i]}});
    ports[port] = {{"differing", d.differing}, {"one_sided", d.one_sided}, {"first_cycle", d.first->cycle},
                   {"elements", elements}};
  }
  fmt::print("{}\n", json{{"component", result.component}, {"cycles", result.cycles},
                          {"logged_seconds", static_cast<double>(result.logged_span_ns) / 1e9},
                          {"replay_seconds", result.replay_seconds}, {"times_real_time", times_real_time(result)},
                          {"writes", result.writes}, {"differing", result.differing}, {"unjudged", result.unjudged},
                          {"unanswered_reads", result.unanswered_reads}, {"unused_answers", result.unused_answers},
                          {"ports", ports}, {"warnings", result.warnings}}
                         .dump());
}

void print_text(const ReplayResult& result, const std::map<std::string, PortDifference>& by_port, std::size_t show) {
  for (const auto& w : result.warnings) fmt::print(stderr, "rtm replay: {}\n", terminal_text(w));
  fmt::print("{}: {} cycles replayed ({:.2f} s logged) in {:.3f} s: {:.0f}x real time\n", result.component, result.cycles,
             static_cast<double>(result.logged_span_ns) / 1e9, result.replay_seconds, times_real_time(result));
  if (result.unjudged > 0)
    fmt::print("{} cycles not compared: the log lost part of them while it was written\n", result.unjudged);
  if (result.unanswered_reads > 0 || result.unused_answers > 0)
    fmt::print("the replay read differently from the run: {} reads beyond the log's (answered: no data), {} logged reads "
               "not made\n",
               result.unanswered_reads, result.unused_answers);
  if (result.differing == 0) {
    fmt::print("{} writes compared: all identical to the log, byte for byte\n", result.writes);
    return;
  }
  fmt::print("{} of {} writes differ from the log\n", result.differing, result.writes);
  for (const auto& [port, d] : by_port) {
    fmt::print("  {}: {} differ, the first in cycle {}{}\n", port, d.differing, d.first->cycle,
               d.one_sided > 0 ? fmt::format(" ({} written on one side only)", d.one_sided) : std::string());
    for (std::size_t i = 0; i < d.largest.size(); ++i) {
      if (d.largest[i] == 0) continue;
      fmt::print("    {}: largest difference {:.6g} (cycle {})\n", i < d.labels.size() ? d.labels[i] : std::to_string(i),
                 d.largest[i], d.at_cycle[i]);
    }
  }
  std::size_t shown = 0;
  for (const auto& m : result.mismatches) {
    if (shown++ >= show) break;
    const auto& tc = result.types.at(m.port);
    const auto text = [&](const std::vector<std::uint8_t>& bytes) {
      return bytes.empty() ? std::string("(nothing)") : format_text(from_cdr(tc.in(), bytes));
    };
    fmt::print("  cycle {} {}: logged {}\n  {:>{}}  replayed {}\n", m.cycle, m.port, terminal_text(text(m.logged)), "",
               fmt::formatted_size("cycle {} {}:", m.cycle, m.port), terminal_text(text(m.replayed)));
  }
}

}  // namespace

int ReplayCommand::run(bool json_output) const {
  const CycleLogInfo info = read_cycle_log_info(log);
  rtm::Orb orb;  // the encodings' code sets; no naming service, no endpoint used
  ReplayOptions replay_options;
  auto component = build(program, component_args, info, replay_options);
  replay_options.output = output;
  replay_options.parameters = parameter_settings(set);
  replay_options.keep = 100'000;
  // What the component logs while replayed (an input going stale, ...) it logged in the run too.
  const auto level = rtm::log().level();
  rtm::log().set_level(spdlog::level::err);
  const ReplayResult result = replay_cycle_log(std::move(component), log, replay_options);
  rtm::log().set_level(level);
  const auto by_port = differences(result);
  if (json_output) {
    print_json(result, by_port);
  } else {
    print_text(result, by_port, show);
    if (!output.empty()) fmt::print("replayed outputs: {}\n", output);
  }
  return result.differing == 0 ? 0 : 1;
}

}  // namespace rtm::cli
