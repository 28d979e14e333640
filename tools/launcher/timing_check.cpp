// SPDX-License-Identifier: Apache-2.0
#include "launcher/timing_check.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstring>

namespace rtm::cli {
namespace {

struct Answer {
  int status = -1;     // exit status; -1: killed or not started
  std::string output;  // stdout and stderr, in the order written
};

// Runs argv (argv[0] a path) with its output captured, for at most timeout; no shell.
Answer run_captured(const std::vector<std::string>& argv, std::chrono::milliseconds timeout) {
  int pipe_fds[2];
  if (::pipe2(pipe_fds, O_CLOEXEC) != 0) throw SystemFileError(fmt::format("pipe: {}", std::strerror(errno)));
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(pipe_fds[0]);
    ::close(pipe_fds[1]);
    throw SystemFileError(fmt::format("fork: {}", std::strerror(errno)));
  }
  if (pid == 0) {
    ::dup2(pipe_fds[1], STDOUT_FILENO);
    ::dup2(pipe_fds[1], STDERR_FILENO);
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  ::close(pipe_fds[1]);
  Answer answer;
  const auto until = std::chrono::steady_clock::now() + timeout;
  bool killed = false;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(until - std::chrono::steady_clock::now());
    pollfd p{pipe_fds[0], POLLIN, 0};
    if (left.count() <= 0 || ::poll(&p, 1, static_cast<int>(left.count())) == 0) {
      ::kill(pid, SIGKILL);
      killed = true;
      break;
    }
    char buffer[4096];
    const ssize_t n = ::read(pipe_fds[0], buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    // Bounded: a contract is one line; a program that says more is not answering.
    if (answer.output.size() < 64 * 1024) answer.output.append(buffer, static_cast<std::size_t>(n));
  }
  ::close(pipe_fds[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  answer.status = !killed && WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return answer;
}

std::string first_line(const std::string& text) {
  const std::size_t end = text.find('\n');
  return text.substr(0, end == std::string::npos ? text.size() : end);
}

}  // namespace

std::optional<TimingContract> parse_contract_json(const std::string& line, const std::string& component) {
  const auto bad = [&](const std::string& what) {
    return SystemFileError(fmt::format("{}: its program's --print-contract is not a contract: {}", component, what));
  };
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(line);
  } catch (const nlohmann::json::exception& e) {
    throw bad(e.what());
  }
  if (!j.is_object()) throw bad("not a JSON object");
  if (j.contains("contract") && j["contract"].is_null()) return std::nullopt;
  TimingContract c;
  c.component = component;
  try {
    c.period_ns = j.at("period_ns").get<std::int64_t>();
    if (!j.at("phase_ns").is_null()) c.phase_ns = j.at("phase_ns").get<std::int64_t>();
    c.deadline_ns = j.at("deadline_ns").get<std::int64_t>();
    c.budget_ns = j.at("budget_ns").get<std::int64_t>();
    c.await_ns = j.at("await_ns").get<std::int64_t>();
    c.await_port = j.value("await_port", std::string());
    c.cpu = j.at("cpu").get<int>();
    c.fifo_priority = j.at("fifo_priority").get<int>();
    c.runtime_ns = j.at("runtime_ns").get<std::int64_t>();
    const auto sched = j.at("sched").get<std::string>();
    if (sched == "fifo")
      c.sched = SchedClass::fifo;
    else if (sched == "deadline")
      c.sched = SchedClass::deadline;
    else if (sched == "other")
      c.sched = SchedClass::other;
    else
      throw bad("sched '" + sched + "' is none of other, fifo, deadline");
    const auto on_miss = parse_miss_action(j.at("on_miss").get<std::string>());
    if (!on_miss) throw bad("on_miss '" + j.at("on_miss").get<std::string>() + "' is none of count, warn, brake");
    c.on_miss = *on_miss;
  } catch (const nlohmann::json::exception& e) {
    throw bad(e.what());
  }
  return c;
}

TimingCheck check_timing(const SystemFile& file, const MachineLimits& machine, const ProgramFinder& find) {
  const auto base = file.path.parent_path();
  TimingCheck check;
  std::vector<TimingFinding> unanswered;
  for (const auto& component : file.components) {
    std::vector<std::string> argv = component.arguments();
    argv[0] = find(argv[0], base).string();
    argv.insert(argv.end(), {"--name", component.name, "--print-contract"});
    const Answer answer = run_captured(argv, std::chrono::seconds(5));
    if (answer.status != 0) {
      unanswered.push_back({TimingFinding::Severity::warning, component.name,
                            answer.status < 0 ? "its program did not declare a contract within 5 s"
                                              : fmt::format("its program declared no contract (exit {}: {})", answer.status,
                                                            first_line(answer.output))});
      continue;
    }
    // The contract is the last line: a program may log before it.
    std::string output = answer.output;
    while (!output.empty() && output.back() == '\n') output.pop_back();
    const std::size_t last = output.rfind('\n');
    const std::string line = last == std::string::npos ? output : output.substr(last + 1);
    if (auto contract = parse_contract_json(line, component.name))
      check.contracts.push_back(std::move(*contract));
    else
      check.without_loop.push_back(component.name);  // a composite of the paper's kind: no loop of its own
  }
  check.analysis = analyse_timing(check.contracts, file.chains, machine);
  check.analysis.findings.insert(check.analysis.findings.begin(), unanswered.begin(), unanswered.end());
  return check;
}

std::string timing_check_json(const TimingCheck& check) {
  using nlohmann::json;
  const TimingAnalysis& a = check.analysis;
  json out;
  out["contracts"] = json::array();
  for (const auto& c : check.contracts) {
    out["contracts"].push_back({{"component", c.component},
                                {"period_ns", c.period_ns},
                                {"phase_ns", c.phase_ns ? json(*c.phase_ns) : json(nullptr)},
                                {"deadline_ns", c.effective_deadline_ns()},
                                {"budget_ns", c.budget_ns},
                                {"await_ns", c.await_ns},
                                {"await_port", c.await_port},
                                {"cpu", c.cpu},
                                {"sched", sched_class_name(c.sched)},
                                {"fifo_priority", c.fifo_priority},
                                {"runtime_ns", c.runtime_ns},
                                {"on_miss", miss_action_name(c.on_miss)}});
  }
  out["cpus"] = json::array();
  for (const auto& cpu : a.cpus) {
    json shares = json::object();
    for (const auto& s : cpu.shares) shares[s.component] = s.utilisation;
    out["cpus"].push_back(
        {{"cpu", cpu.cpu}, {"utilisation", cpu.utilisation}, {"rt_utilisation", cpu.rt_utilisation}, {"shares", shares}});
  }
  out["unpinned_utilisation"] = a.unpinned_utilisation;
  out["responses"] = json::array();
  for (const auto& r : a.responses) {
    out["responses"].push_back({{"component", r.component},
                                {"response_ns", r.response_ns ? json(*r.response_ns) : json(nullptr)},
                                {"how", r.how}});
  }
  out["chains"] = json::array();
  for (const auto& c : a.chains) {
    json hops = json::array();
    for (const auto& h : c.hops) {
      hops.push_back({{"writer", h.writer}, {"reader", h.reader}, {"latency_ns", h.latency_ns}, {"age_ns", h.age_ns}, {"how", h.how}});
    }
    out["chains"].push_back({{"name", c.name},
                             {"hops", hops},
                             {"latency_ns", c.latency_ns ? json(*c.latency_ns) : json(nullptr)},
                             {"age_ns", c.age_ns ? json(*c.age_ns) : json(nullptr)},
                             {"how", c.how}});
  }
  out["findings"] = json::array();
  for (const auto& f : a.findings) {
    out["findings"].push_back({{"severity", f.severity == TimingFinding::Severity::refusal ? "refusal" : "warning"},
                               {"subject", f.subject},
                               {"text", f.text}});
  }
  out["without_loop"] = check.without_loop;
  out["refused"] = a.refused();
  return out.dump(2);
}

}  // namespace rtm::cli
