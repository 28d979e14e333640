// SPDX-License-Identifier: Apache-2.0
// System files as `rtm up` reads them, and port addresses as every command parses them.
#include "browser/browser.h"
#include "launcher/launcher.h"
#include "launcher/running_system.h"
#include "launcher/system_file.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <unistd.h>

using rtm::ConnPolicy;
using rtm::ReaderPolicy;

namespace {

using rtm::cli::SystemFile;
using rtm::cli::SystemFileError;

const std::filesystem::path kFile = "/srv/systems/servo.yaml";

std::string error_of(const std::string& yaml) {
  try {
    SystemFile::parse(yaml, kFile);
  } catch (const SystemFileError& e) {
    return e.what();
  }
  return "";
}

TEST(RtmSystemFile, ReadsComponentsConnectionsAndActivation) {
  auto f = SystemFile::parse(R"(
name: servo
naming: 127.0.0.1:2999
components:
  - name: src
    command: [rtm-example-source, --period, 2ms]
  - name: sink
    command: rtm-example-sink
connections:
  - {from: src.out0, to: sink.in0}
  - {from: src.out0, to: sink.in1, type: once}
  - {from: src.out0, to: sink.in2, policy: "reader=fifo:16, depth=32 delivery=thread call=250ms path=corba"}
activate: [src, sink]
)", kFile);
  EXPECT_EQ(f.name, "servo");
  EXPECT_EQ(f.naming, "127.0.0.1:2999");
  ASSERT_EQ(f.components.size(), 2u);
  EXPECT_EQ(f.components[0].command, (std::vector<std::string>{"rtm-example-source", "--period", "2ms"}));
  EXPECT_EQ(f.components[1].command, (std::vector<std::string>{"rtm-example-sink"}));
  ASSERT_EQ(f.connections.size(), 3u);
  EXPECT_EQ(f.connections[0].policy, ConnPolicy::repeated());
  EXPECT_EQ(f.connections[1].policy, ConnPolicy::one_shot());
  const ConnPolicy& p = f.connections[2].policy;
  EXPECT_FALSE(p.once);
  EXPECT_EQ(p.reader, (ReaderPolicy{ReaderPolicy::Kind::fifo, 16}));
  EXPECT_EQ(p.depth, 32u);
  EXPECT_EQ(p.delivery, ConnPolicy::Delivery::thread);
  EXPECT_EQ(p.call_timeout_ms, 250u);
  EXPECT_TRUE(p.corba_only);
  EXPECT_EQ(f.activate, (std::vector<std::string>{"src", "sink"}));
}

TEST(RtmSystemFile, ToYamlReadsBackToTheSameSystemQuotingWhatNeedsIt) {
  SystemFile f;
  f.path = kFile;
  f.name = "saved";
  f.naming = "127.0.0.1:2999";
  f.components = {{"src", {"/opt/rtm/bin/rtm-example-source", "--period", "2ms", "--note", "a: b, [c]"}, {}, {}},
                  {"sink", {"rtm-example-sink"}, {{"gain", "0.5 0.5 0 0 0 0"}, {"note", "a: b"}},
                   {{"soft", {{"gain", "0.1 0.1 0 0 0 0"}}}}}};
  ConnPolicy deep = ConnPolicy::one_shot();
  deep.depth = 64;
  deep.reader = {ReaderPolicy::Kind::latest, 0};
  f.connections = {{"src.out0", "sink.in0", ConnPolicy::repeated()},
                   {"src.out0", "sink.in1", ConnPolicy::one_shot()},
                   {"src.out0", "sink.in2", deep}};
  f.activate = {"src"};
  const SystemFile back = SystemFile::parse(f.to_yaml(), kFile);
  EXPECT_EQ(back.name, "saved");
  EXPECT_EQ(back.naming, f.naming);
  ASSERT_EQ(back.components.size(), 2u);
  EXPECT_EQ(back.components[0].command, f.components[0].command);
  EXPECT_EQ(back.components[1].parameters, f.components[1].parameters) << "in their order";
  EXPECT_EQ(back.components[1].parameter_sets, f.components[1].parameter_sets);
  ASSERT_EQ(back.connections.size(), 3u);
  EXPECT_EQ(back.connections[1].to, "sink.in1");
  EXPECT_EQ(back.connections[0].policy, ConnPolicy::repeated());
  EXPECT_EQ(back.connections[1].policy, ConnPolicy::one_shot());
  EXPECT_EQ(back.connections[2].policy, deep);
  EXPECT_EQ(back.activate, f.activate);
}

TEST(RtmSystemFile, AComponentsParametersAreKeptAsTheTextRtmSetTakesInTheFilesOrder) {
  auto f = SystemFile::parse("components:\n"
                             "  - name: c\n"
                             "    command: rtm-controller\n"
                             "    parameters:\n"
                             "      stale_periods: 3\n"
                             "      gain: [0.0004, 0.0004, 0.0004, 0, 0, 0]\n"
                             "      approach_speed: \"0.01\"\n",
                             kFile);
  ASSERT_EQ(f.components.size(), 1u);
  EXPECT_EQ(f.components[0].parameters,
            (std::vector<std::pair<std::string, std::string>>{
                {"stale_periods", "3"}, {"gain", "0.0004 0.0004 0.0004 0 0 0"}, {"approach_speed", "0.01"}}));
}

TEST(RtmSystemFile, AParameterSetsValuesGoOverTheComponentsParametersAndJoinThem) {
  auto f = SystemFile::parse("components:\n"
                             "  - name: c\n"
                             "    command: rtm-controller\n"
                             "    parameters: {stale_periods: 3, approach_speed: 0.005}\n"
                             "    parameter_sets:\n"
                             "      soft: {approach_speed: 0.002, contact_force: 2}\n"
                             "  - {name: d, command: x, parameter_sets: {firm: {gain: 1}}}\n",
                             kFile);
  using P = rtm::cli::SystemFile::Component::Parameters;
  EXPECT_EQ(f.components[0].parameters_with("soft"),
            (P{{"stale_periods", "3"}, {"approach_speed", "0.002"}, {"contact_force", "2"}}));
  EXPECT_EQ(f.components[0].parameters_with(""), f.components[0].parameters);
  EXPECT_EQ(f.components[0].parameters_with("firm"), f.components[0].parameters) << "a set it does not have";
  EXPECT_EQ(f.parameter_set_names(), (std::vector<std::string>{"firm", "soft"}));
}

TEST(RtmSystemFile, MalformedParametersAndUnknownComponentKeysAreRefusedWithTheLine) {
  const auto refusal = [](const std::string& yaml) {
    try {
      SystemFile::parse(yaml, kFile);
    } catch (const rtm::cli::SystemFileError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(refusal("components:\n  - {name: c, command: x, parameters: [1, 2]}\n")
                .find("component 'c': 'parameters' must be a mapping of names to values"),
            std::string::npos);
  EXPECT_NE(refusal("components:\n  - {name: c, command: x, parameters: {gain: {a: 1}}}\n")
                .find("component 'c': parameter 'gain' must be a non-empty string"),
            std::string::npos);
  EXPECT_NE(refusal("components:\n  - name: c\n    command: x\n    parameters: {gain: 1, gain: 2}\n").find("given twice"),
            std::string::npos)
      << "or YAML's own refusal of a repeated key";
  const std::string unknown = refusal("components:\n  - name: c\n    command: x\n    paramters: {gain: 1}\n");
  EXPECT_NE(unknown.find(
                ":4: unknown key 'paramters' in a component (known: name, command, host, parameters, parameter_sets, contract)"),
            std::string::npos)
      << unknown;
}

TEST(RtmSystemFile, TheExampleOfTheDocsIsAFileRtmUpTakes) {
  std::ifstream in(std::string(RTM_SOURCE_DIR) + "/docs/system-files.md");
  ASSERT_TRUE(in) << "docs/system-files.md";
  std::string yaml, line;
  bool inside = false;
  while (std::getline(in, line)) {
    if (!inside && line == "```yaml") {
      inside = true;
    } else if (inside && line == "```") {
      break;
    } else if (inside) {
      yaml += line + "\n";
    }
  }
  const SystemFile f = SystemFile::parse(yaml, kFile);
  EXPECT_EQ(f.name, "gripper");
  ASSERT_EQ(f.components.size(), 3u);
  EXPECT_EQ(f.components[1].parameters.size(), 2u);
  EXPECT_EQ(f.parameter_set_names(), (std::vector<std::string>{"gentle"}));
  EXPECT_EQ(f.components[1].parameters_with("gentle").size(), 3u) << "gain replaced, approach_speed joined";
  EXPECT_EQ(f.connections.size(), 2u);
  EXPECT_EQ(f.activate.size(), 3u);
}

TEST(RtmSystemFile, NameDefaultsToTheFileStem) {
  auto f = SystemFile::parse("components: [{name: a, command: x}]", kFile);
  EXPECT_EQ(f.name, "servo");
}

TEST(RtmSystemFile, BadYamlNamesFileAndLine) {
  EXPECT_EQ(error_of("components:\n  - name: [unclosed\n").rfind("/srv/systems/servo.yaml:", 0), 0u);
}

TEST(RtmSystemFile, UnknownKeyIsRefusedNotIgnored) {
  EXPECT_NE(error_of("components: [{name: a, command: x}]\nactivte: [a]\n").find("unknown key 'activte'"),
            std::string::npos);
}

TEST(RtmSystemFile, ComponentWithoutCommandIsRefused) {
  EXPECT_NE(error_of("components: [{name: a}]").find("component 'a' needs a 'command'"), std::string::npos);
}

TEST(RtmSystemFile, AMissingKeyIsNamedWithTheFileAndTheLineOfItsMapping) {
  EXPECT_EQ(error_of("components:\n  - {name: a, command: x}\nconnections:\n  - {from: a.out0}\n"),
            "/srv/systems/servo.yaml:4: a connection's 'to' is missing");
  EXPECT_EQ(error_of("components:\n  - {command: x}\n"), "/srv/systems/servo.yaml:2: a component's 'name' is missing");
}

TEST(RtmSystemFile, DuplicateComponentIsRefused) {
  EXPECT_NE(error_of("components: [{name: a, command: x}, {name: a, command: y}]").find("listed twice"),
            std::string::npos);
}

TEST(RtmSystemFile, ConnectionToUnlistedComponentIsRefused) {
  EXPECT_NE(error_of("components: [{name: a, command: x}]\nconnections: [{from: a.out0, to: b.in0}]")
                .find("names component 'b'"),
            std::string::npos);
}

TEST(RtmSystemFile, AnInPortWrittenTwiceIsRefusedNamingItAndBothWriters) {
  const auto error = error_of(
      "components: [{name: a, command: x}, {name: b, command: y}, {name: c, command: z}]\n"
      "connections: [{from: a.force, to: c.in0}, {from: b.force, to: c.in0}]");
  EXPECT_NE(error.find("/srv/systems/servo.yaml: the wiring does not hold"), std::string::npos) << error;
  EXPECT_NE(error.find("c.in0 has two writers, a.force and b.force"), std::string::npos) << error;
}

TEST(RtmSystemFile, ItsDiagramHasItsComponentsAndConnectionsWithTheirPolicies) {
  const auto file = SystemFile::parse("components: [{name: a, command: x}, {name: b, command: y}]\n"
                                      "connections: [{from: a.force, to: b.in0, type: once}]",
                                      kFile);
  const auto d = file.diagram();
  ASSERT_EQ(d.members.size(), 2u);
  EXPECT_EQ(d.members[1].name, "b");
  EXPECT_FALSE(d.ticked);
  ASSERT_EQ(d.connections.size(), 1u);
  EXPECT_EQ(d.connections[0].text(), "a.force -> b.in0");
  EXPECT_TRUE(d.connections[0].policy.once);
}

TEST(RtmSystemFile, BadConnectionTypeIsRefused) {
  EXPECT_NE(error_of("components: [{name: a, command: x}]\n"
                     "connections: [{from: a.out0, to: a.in0, type: twice}]")
                .find("neither 'once' nor 'repeated'"),
            std::string::npos);
}

TEST(RtmSystemFile, ABadConnectionPolicyIsRefusedNamingTheTokenAndTheLine) {
  const std::string head = "components: [{name: a, command: x}, {name: b, command: y}]\nconnections:\n";
  const std::string depth = error_of(head + "  - {from: a.out0, to: b.in0, policy: \"depth=lots\"}\n");
  EXPECT_NE(depth.find("servo.yaml:3"), std::string::npos) << depth;
  EXPECT_NE(depth.find("'depth=lots'"), std::string::npos) << depth;
  const std::string key = error_of(head + "  - {from: a.out0, to: b.in0, policy: \"buffer=4\"}\n");
  EXPECT_NE(key.find("unknown key"), std::string::npos) << key;
  const std::string typo = error_of(head + "  - {from: a.out0, to: b.in0, polcy: \"depth=4\"}\n");
  EXPECT_NE(typo.find("unknown key 'polcy' in a connection"), std::string::npos) << typo;
  const std::string clash = error_of(head + "  - {from: a.out0, to: b.in0, type: once, policy: \"repeated\"}\n");
  EXPECT_NE(clash.find("disagree"), std::string::npos) << clash;
  // The same lifetime twice is no clash.
  EXPECT_EQ(error_of(head + "  - {from: a.out0, to: b.in0, type: once, policy: \"once depth=2\"}\n"), "");
}

TEST(RtmSystemFile, ActivatingUnlistedComponentIsRefused) {
  EXPECT_NE(error_of("components: [{name: a, command: x}]\nactivate: [z]").find("'activate' names 'z'"),
            std::string::npos);
}

TEST(RtmSystemFile, EmptyComponentListIsRefused) {
  EXPECT_NE(error_of("components: []").find("non-empty list"), std::string::npos);
}

TEST(RtmSystemFile, MissingFileIsAClearError) {
  EXPECT_THROW(SystemFile::load("/nonexistent/dir/system.yaml"), SystemFileError);
}

TEST(RtmSystemFile, ProgramsAreFoundOnRtmBinPathThenPath) {
  const auto dir = std::filesystem::temp_directory_path() / ("rtm-find-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto prog = dir / "rtm-fake-component";
  std::ofstream(prog) << "#!/bin/sh\n";
  std::filesystem::permissions(prog, std::filesystem::perms::owner_all);
  ::setenv("RTM_BIN_PATH", dir.c_str(), 1);
  EXPECT_EQ(rtm::cli::find_program("rtm-fake-component", "/"), prog);
  EXPECT_THROW(rtm::cli::find_program("rtm-no-such-program", "/"), SystemFileError);
  EXPECT_EQ(rtm::cli::find_program("./rtm-fake-component", dir), dir / "./rtm-fake-component");
  ::unsetenv("RTM_BIN_PATH");
  std::filesystem::remove_all(dir);
}

TEST(RtmSystemFile, AHostGroupsComponentsAndIsWrittenBack) {
  const auto f = SystemFile::parse("components:\n"
                                   "  - {name: a, command: x, host: arm}\n"
                                   "  - {name: b, command: [y, --, z]}\n"
                                   "  - name: c\n"
                                   "    command: [./bin/w, -v]\n"
                                   "    host: arm\n",
                                   kFile);
  ASSERT_EQ(f.components.size(), 3u);
  EXPECT_EQ(f.components[0].host, "arm");
  EXPECT_EQ(f.components[1].host, "") << "no host: a process of its own, whose command may hold '--'";
  EXPECT_EQ(f.components[2].host, "arm");
  const SystemFile back = SystemFile::parse(f.to_yaml(), kFile);
  ASSERT_EQ(back.components.size(), 3u);
  EXPECT_EQ(back.components[0].host, "arm");
  EXPECT_EQ(back.components[1].host, "");
  EXPECT_EQ(back.components[2].host, "arm");
}

TEST(RtmSystemFile, AHostNamedLikeAComponentOrADoubleDashInAMembersCommandIsRefusedWithTheLine) {
  EXPECT_EQ(error_of("components:\n"
                     "  - {name: a, command: x}\n"
                     "  - name: b\n"
                     "    command: y\n"
                     "    host: a\n"),
            "/srv/systems/servo.yaml:5: component 'b': host 'a' is also a component's name (a host needs a name "
            "of its own)");
  EXPECT_EQ(error_of("components:\n"
                     "  - name: b\n"
                     "    host: h\n"
                     "    command: y\n"
                     "  - {name: a, command: x, host: b}\n"),
            "/srv/systems/servo.yaml:5: component 'a': host 'b' is also a component's name (a host needs a name "
            "of its own)")
      << "a component listed after the host's name is found too";
  EXPECT_EQ(error_of("components:\n"
                     "  - name: a\n"
                     "    host: h\n"
                     "    command:\n"
                     "      - x\n"
                     "      - --gain\n"
                     "      - \"--\"\n"
                     "      - y\n"),
            "/srv/systems/servo.yaml:7: component 'a' runs in host 'h': its command may not hold '--' "
            "(rtm-container separates its members with it)");
  EXPECT_EQ(error_of("components:\n  - {name: a, host: h, command: \"--\"}\n"),
            "/srv/systems/servo.yaml:2: component 'a' runs in host 'h': its command may not hold '--' "
            "(rtm-container separates its members with it)");
  const std::string bad =
      error_of("components:\n  - {name: a, command: x}\n  - {name: b, command: y, host: \"a/b\"}\n");
  EXPECT_EQ(bad.rfind("/srv/systems/servo.yaml:3: host name 'a/b': holds '/'", 0), 0u) << bad;
  const std::string empty = error_of("components:\n  - {name: b, command: y, host: \"\"}\n");
  EXPECT_EQ(empty.rfind("/srv/systems/servo.yaml:2: component 'b': 'host' must be a non-empty string", 0), 0u)
      << empty;
}

// A finder that answers without a filesystem, and keeps what it was asked.
struct FakeFinder {
  std::vector<std::string> asked;
  std::filesystem::path operator()(const std::string& program, const std::filesystem::path& base) {
    asked.push_back(program);
    if (program.find('/') != std::string::npos) return base / program;
    return std::filesystem::path("/opt/rtm/bin") / program;
  }
};

TEST(RtmLauncher, AHostIsOneContainerWithItsMembersInTheFilesOrderBesideALoneComponent) {
  const auto f =
      SystemFile::parse("components:\n"
                        "  - {name: sensor0, command: [rtm-sensor, --bus, \"local:/tmp/pa10.bus\"], host: arm}\n"
                        "  - {name: logger0, command: [./bin/rtm-logger, --dir, /tmp/arm]}\n"
                        "  - {name: controller0, command: [./bin/ctl, --gain, \"2\"], host: arm}\n",
                        kFile);
  FakeFinder finder;
  const auto starts = rtm::cli::processes_to_start(f, "127.0.0.1:2809", std::ref(finder));
  ASSERT_EQ(starts.size(), 2u);
  EXPECT_EQ(starts[0].name, "arm");
  EXPECT_EQ(starts[0].command,
            (std::vector<std::string>{"/opt/rtm/bin/rtm-container", "--name", "arm", "--naming", "127.0.0.1:2809",
                                      "--", "sensor0", "/opt/rtm/bin/rtm-sensor", "--bus", "local:/tmp/pa10.bus",
                                      "--", "controller0", "/srv/systems/./bin/ctl", "--gain", "2"}));
  EXPECT_EQ(starts[0].members, (std::vector<std::string>{"sensor0", "controller0"}));
  EXPECT_EQ(starts[1].name, "logger0");
  EXPECT_EQ(starts[1].command,
            (std::vector<std::string>{"/srv/systems/./bin/rtm-logger", "--dir", "/tmp/arm", "--name", "logger0",
                                      "--naming", "127.0.0.1:2809"}));
  EXPECT_EQ(starts[1].members, (std::vector<std::string>{"logger0"}));
  EXPECT_EQ(finder.asked, (std::vector<std::string>{"rtm-container", "rtm-sensor", "./bin/rtm-logger", "./bin/ctl"}))
      << "every program looked for once, the container once";
}

TEST(RtmLauncher, WithoutHostsEachComponentIsAProcessOfItsOwnAsBefore) {
  const auto f = SystemFile::parse("components: [{name: a, command: [x, --, y]}, {name: b, command: z}]", kFile);
  FakeFinder finder;
  const auto starts = rtm::cli::processes_to_start(f, "127.0.0.1:2999", std::ref(finder));
  ASSERT_EQ(starts.size(), 2u);
  EXPECT_EQ(starts[0].command,
            (std::vector<std::string>{"/opt/rtm/bin/x", "--", "y", "--name", "a", "--naming", "127.0.0.1:2999"}));
  EXPECT_EQ(starts[1].command,
            (std::vector<std::string>{"/opt/rtm/bin/z", "--name", "b", "--naming", "127.0.0.1:2999"}));
  EXPECT_EQ(starts[1].members, (std::vector<std::string>{"b"}));
}

TEST(RtmLauncher, TheContainerIsFoundOnRtmBinPathAndItsAbsenceStartsNothing) {
  const auto dir = std::filesystem::temp_directory_path() / ("rtm-container-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto f = SystemFile::parse("components: [{name: a, command: rtm-sensor, host: h}]", kFile);
  const char* old_path = std::getenv("PATH");
  const std::string saved_path = old_path ? old_path : "";
  ::setenv("RTM_BIN_PATH", dir.c_str(), 1);
  ::setenv("PATH", dir.c_str(), 1);
  EXPECT_THROW(rtm::cli::processes_to_start(f, "127.0.0.1:2809"), SystemFileError);
  const auto container = dir / "rtm-container";
  std::ofstream(container) << "#!/bin/sh\n";
  std::filesystem::permissions(container, std::filesystem::perms::owner_all);
  const auto starts = rtm::cli::processes_to_start(f, "127.0.0.1:2809");
  ::setenv("PATH", saved_path.c_str(), 1);
  ::unsetenv("RTM_BIN_PATH");
  std::filesystem::remove_all(dir);
  ASSERT_EQ(starts.size(), 1u);
  EXPECT_EQ(starts[0].command,
            (std::vector<std::string>{container.string(), "--name", "h", "--naming", "127.0.0.1:2809", "--", "a",
                                      "rtm-sensor"}));
}

TEST(RtmLauncher, TheStateKeepsOnePidPerProcessAndTheMembersOfEach) {
  const auto dir = std::filesystem::temp_directory_path() / ("rtm-state-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const char* old_runtime = std::getenv("XDG_RUNTIME_DIR");
  const std::string saved_runtime = old_runtime ? old_runtime : "";
  ::setenv("XDG_RUNTIME_DIR", dir.c_str(), 1);
  rtm::cli::SystemState state;
  state.system = "arm";
  state.naming = "127.0.0.1:2809";
  state.file = kFile;
  state.processes = {{"servo", 101, 7, dir / "servo.log", {"sensor0", "controller0"}},
                     {"logger0", 102, 8, dir / "logger0.log", {"logger0"}}};
  state.save();
  const auto back = rtm::cli::SystemState::load("arm");
  // A state file of an older build: no members, a process was one component.
  std::ofstream(rtm::cli::SystemState::path_for("old"))
      << "system: old\nnaming: 127.0.0.1:2809\nfile: /srv/systems/old.yaml\n"
         "processes:\n  - {name: a, pid: 5, start: 9, log: /tmp/a.log}\nconnections: []\nactivated: []\n";
  const auto old = rtm::cli::SystemState::load("old");
  if (old_runtime)
    ::setenv("XDG_RUNTIME_DIR", saved_runtime.c_str(), 1);
  else
    ::unsetenv("XDG_RUNTIME_DIR");
  std::filesystem::remove_all(dir);
  ASSERT_EQ(back.processes.size(), 2u);
  EXPECT_EQ(back.processes[0].name, "servo");
  EXPECT_EQ(back.processes[0].pid, 101);
  EXPECT_EQ(back.processes[0].members, (std::vector<std::string>{"sensor0", "controller0"}));
  EXPECT_EQ(back.processes[1].members, (std::vector<std::string>{"logger0"}));
  ASSERT_EQ(old.processes.size(), 1u);
  EXPECT_EQ(old.processes[0].members, (std::vector<std::string>{"a"}));
}

TEST(RtmSystemFile, TheHostExampleOfTheDocsIsAFileRtmUpTakes) {
  std::ifstream in(std::string(RTM_SOURCE_DIR) + "/docs/system-files.md");
  ASSERT_TRUE(in) << "docs/system-files.md";
  std::vector<std::string> blocks;
  std::string line;
  bool inside = false;
  while (std::getline(in, line)) {
    if (!inside && line == "```yaml") {
      inside = true;
      blocks.emplace_back();
    } else if (inside && line == "```") {
      inside = false;
    } else if (inside) {
      blocks.back() += line + "\n";
    }
  }
  const auto example =
      std::find_if(blocks.begin(), blocks.end(), [](const std::string& b) { return b.find("host: ") != b.npos; });
  ASSERT_NE(example, blocks.end()) << "an example with 'host:'";
  const SystemFile f = SystemFile::parse(*example, kFile);
  FakeFinder finder;
  const auto starts = rtm::cli::processes_to_start(f, "127.0.0.1:2809", std::ref(finder));
  ASSERT_EQ(starts.size(), 2u);
  EXPECT_EQ(starts[0].name, "servo");
  EXPECT_EQ(starts[0].members, (std::vector<std::string>{"sensor0", "controller0"}));
  EXPECT_EQ(starts[1].members, (std::vector<std::string>{"logger0"}));
}

TEST(RtmRunningSystem, AToolsInPortIsKnownByItsOwnersPrefixWithItsDash) {
  EXPECT_TRUE(rtm::cli::is_tool_subscriber("rtm-record-123.in"));
  EXPECT_TRUE(rtm::cli::is_tool_subscriber("rtm-serve-ab.plot0"));
  EXPECT_TRUE(rtm::cli::is_tool_subscriber("rtm-watch-7.in"));
  EXPECT_TRUE(rtm::cli::is_tool_subscriber("rtm-play-7.in"));
  EXPECT_FALSE(rtm::cli::is_tool_subscriber("controller0.in0"));
  EXPECT_FALSE(rtm::cli::is_tool_subscriber("rtm-recorder0.in"));
  EXPECT_FALSE(rtm::cli::is_tool_subscriber(""));
}

TEST(RtmPortAddress, SplitsAtTheLastDot) {
  auto a = rtm::cli::PortAddress::parse("host.example/sensor0.out0");
  EXPECT_EQ(a.component, "host.example/sensor0");
  EXPECT_EQ(a.port, "out0");
}

TEST(RtmPortAddress, RefusesAddressesWithoutAPort) {
  EXPECT_THROW(rtm::cli::PortAddress::parse("sensor0"), std::invalid_argument);
  EXPECT_THROW(rtm::cli::PortAddress::parse("sensor0."), std::invalid_argument);
  EXPECT_THROW(rtm::cli::PortAddress::parse(".out0"), std::invalid_argument);
}

}  // namespace

namespace {

// ------------------------------------------------------------------ timing contracts

TEST(RtmSystemFile, AContractIsGivenToTheProgramAsOptionsAfterItsOwnSoThatItWins) {
  auto f = SystemFile::parse(R"(
components:
  - name: controller0
    command: [rtm-controller, --phase, 0.5ms]
    contract: {phase: 0.1ms, deadline: 0.5ms, budget: 80us, await: "wrench:0.15ms", cpu: 1, priority: 80, on_miss: warn}
  - {name: joystick0, command: rtm-joystick, contract: {sched_deadline: 100us, period: 4ms}}
)",
                             kFile);
  EXPECT_EQ(f.components[0].arguments(),
            (std::vector<std::string>{"rtm-controller", "--phase", "0.5ms", "--phase", "0.1ms", "--deadline", "0.5ms",
                                      "--budget", "80us", "--await", "wrench:0.15ms", "--cpu", "1", "--rt-priority",
                                      "80", "--on-miss", "warn"}));
  EXPECT_EQ(f.components[1].arguments(),
            (std::vector<std::string>{"rtm-joystick", "--sched-deadline", "100us", "--period", "4ms"}));
  const auto starts = rtm::cli::processes_to_start(f, "127.0.0.1:2809", [](const std::string& p, const auto&) {
    return std::filesystem::path("/opt/rtm/bin") / p;
  });
  ASSERT_EQ(starts.size(), 2u);
  EXPECT_EQ(starts[0].command[2], "0.5ms");
  EXPECT_EQ(starts[0].command[3], "--phase") << "the contract's phase after the command's";
  EXPECT_EQ(starts[0].command[4], "0.1ms");
}

TEST(RtmSystemFile, ChainsAreReadWithTheirBoundsAndWrittenBack) {
  auto f = SystemFile::parse(R"(
name: servo
components:
  - {name: sensor0, command: rtm-sensor, contract: {phase: 0, budget: 50us}}
  - {name: controller0, command: rtm-controller}
  - {name: actuator0, command: rtm-actuator}
chains:
  - {name: wrist_to_twist, path: [sensor0.wrench, controller0, actuator0], deadline: 1ms, max_age: 2.5ms}
  - {name: short, path: [sensor0.wrench, controller0.wrench], on_miss: brake}
)",
                             kFile);
  ASSERT_EQ(f.chains.size(), 2u);
  EXPECT_EQ(f.chains[0].name, "wrist_to_twist");
  EXPECT_EQ(f.chains[0].path, (std::vector<std::string>{"sensor0.wrench", "controller0", "actuator0"}));
  EXPECT_EQ(f.chains[0].deadline_ns, 1'000'000);
  EXPECT_EQ(f.chains[0].max_age_ns, 2'500'000);
  EXPECT_EQ(f.chains[1].deadline_ns, 0) << "none given";
  const auto again = SystemFile::parse(f.to_yaml(), kFile);
  ASSERT_EQ(again.chains.size(), 2u);
  EXPECT_EQ(again.chains[0].path, f.chains[0].path);
  EXPECT_EQ(again.chains[0].deadline_ns, 1'000'000);
  EXPECT_EQ(again.chains[0].max_age_ns, 2'500'000);
  EXPECT_EQ(again.components[0].contract, f.components[0].contract);
  EXPECT_EQ(again.chains[1].on_miss, rtm::MissAction::brake);
  // The chain's end measures it while it runs: the component its last step names by an InPort.
  const auto controller = f.arguments(f.components[1]);
  ASSERT_GE(controller.size(), 2u);
  EXPECT_EQ(controller[controller.size() - 2], "--watch-chain");
  EXPECT_EQ(controller.back(), "short:wrench:0ns:0ns:brake");
  EXPECT_EQ(f.arguments(f.components[2]), f.components[2].command) << "wrist_to_twist names no InPort at its end";
}

TEST(RtmSystemFile, EachComponentInsideAChainDerivesTheStampOfTheOutPortTheChainLeavesByFromWhereItEnters) {
  auto f = SystemFile::parse(R"(
name: chained
components:
  - {name: a, command: rtm-a}
  - {name: b, command: rtm-b}
  - {name: c, command: rtm-c}
  - {name: d, command: rtm-d}
connections:
  - {from: a.force, to: b.in0}
  - {from: a.other, to: b.in1}
  - {from: b.force, to: c.in0}
  - {from: b.side, to: d.in0}
  - {from: c.out0, to: d.in1}
chains:
  - {name: through_c, path: [a.force, b, c.in0, d]}
  - {name: other, path: [a.other, b.in1, c]}
  - {name: sideways, path: [a.force, b, d.in0]}
)",
                             kFile);
  using Derivations = std::vector<std::pair<std::string, std::vector<std::string>>>;
  // b: entered by the port a.force feeds (in0) or, named, in1; left by force (to c) or side (to d).
  EXPECT_EQ(f.stamp_derivations(f.components[1]),
            (Derivations{{"force", {"in0", "in1"}}, {"side", {"in0"}}}));
  EXPECT_EQ(f.stamp_derivations(f.components[2]), (Derivations{{"out0", {"in0"}}})) << "indices as the file gives them";
  EXPECT_TRUE(f.stamp_derivations(f.components[0]).empty()) << "a chain's head writes its own stamp";
  EXPECT_TRUE(f.stamp_derivations(f.components[3]).empty()) << "a chain's end writes nothing on";
  const auto b = f.arguments(f.components[1]);
  EXPECT_EQ(b, (std::vector<std::string>{"rtm-b", "--stamp-from", "force=in0+in1", "--stamp-from", "side=in0"}));
  // A hop no connection of the file shows (a composite wires it inside) derives nothing.
  auto unwired = SystemFile::parse(R"(
name: unwired
components:
  - {name: a, command: rtm-a}
  - {name: b, command: rtm-b}
  - {name: c, command: rtm-c}
chains:
  - {name: ac, path: [a.force, b.in0, c.in0]}
)",
                                   kFile);
  EXPECT_TRUE(unwired.stamp_derivations(unwired.components[1]).empty());
}

TEST(RtmSystemFile, AMalformedContractOrChainIsRefusedWithTheLineAndWhatIsWanted) {
  const std::string head = "components:\n  - {name: a, command: rtm-a}\n  - {name: b, command: rtm-b}\n";
  const auto contract_error = [](const std::string& contract) {
    return error_of("components:\n  - name: a\n    command: rtm-a\n    contract: " + contract + "\n");
  };
  EXPECT_NE(contract_error("{budget: fast}").find("servo.yaml:4: component 'a': contract budget 'fast': want a duration"),
            std::string::npos)
      << contract_error("{budget: fast}");
  EXPECT_NE(contract_error("{period: 10us}").find("from 50us to 1 h"), std::string::npos);
  EXPECT_NE(contract_error("{priority: 100}").find("1..99"), std::string::npos);
  EXPECT_NE(contract_error("{cpu: -1}").find("a CPU's number"), std::string::npos);
  EXPECT_NE(contract_error("{on_miss: panic}").find("count, warn or brake"), std::string::npos);
  EXPECT_NE(contract_error("{await: 0.1ms}").find("PORT:BOUND"), std::string::npos);
  EXPECT_NE(contract_error("{wcet: 1ms}").find("unknown key 'wcet' in a contract"), std::string::npos);
  EXPECT_NE(contract_error("{sched_deadline: 100us, cpu: 1}").find("takes no priority and no cpu"), std::string::npos);
  EXPECT_NE(contract_error("[1ms]").find("'contract' must be a mapping"), std::string::npos);

  EXPECT_NE(error_of(head + "chains:\n  - {name: c, path: [a, b]}\n").find("servo.yaml:5: chain 'c': its path starts at an OutPort"),
            std::string::npos)
      << error_of(head + "chains:\n  - {name: c, path: [a, b]}\n");
  EXPECT_NE(error_of(head + "chains:\n  - {name: c, path: [a.out, b.]}\n").find("after its head the path names components"),
            std::string::npos);
  EXPECT_EQ(error_of(head + "chains:\n  - {name: c, path: [a.out, b.in]}\n"), "") << "a component and its InPort";
  EXPECT_NE(error_of(head + "chains:\n  - {name: c, path: [a.out, z]}\n").find("component 'z', which 'components' does not list"),
            std::string::npos);
  EXPECT_NE(error_of(head + "chains:\n  - {name: c, path: [a.out]}\n").find("'path' must list"), std::string::npos);
  EXPECT_NE(error_of(head + "chains:\n  - {name: c, path: [a.out, b], deadline: soon}\n").find("deadline 'soon'"),
            std::string::npos);
  EXPECT_NE(error_of(head + "chains:\n  - {name: C!, path: [a.out, b]}\n").find("chain name"), std::string::npos);
  EXPECT_NE(error_of(head + "chains:\n  - {name: c, path: [a.out, b]}\n  - {name: c, path: [a.out, b]}\n").find("listed twice"),
            std::string::npos);
  EXPECT_NE(error_of(head + "chains:\n  - {name: c, path: [a.out, b], latency: 1ms}\n").find("unknown key 'latency' in a chain"),
            std::string::npos);
  EXPECT_NE(error_of(head + "chains:\n  - {name: c, path: [a.out, b.in], on_miss: panic}\n").find("on_miss 'panic'"),
            std::string::npos);
}

}  // namespace
