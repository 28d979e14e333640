// SPDX-License-Identifier: Apache-2.0
// System files as `rtm up` reads them, and port addresses as every command parses them.
#include "browser.h"
#include "system_file.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <unistd.h>

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
activate: [src, sink]
)", kFile);
  EXPECT_EQ(f.name, "servo");
  EXPECT_EQ(f.naming, "127.0.0.1:2999");
  ASSERT_EQ(f.components.size(), 2u);
  EXPECT_EQ(f.components[0].command, (std::vector<std::string>{"rtm-example-source", "--period", "2ms"}));
  EXPECT_EQ(f.components[1].command, (std::vector<std::string>{"rtm-example-sink"}));
  ASSERT_EQ(f.connections.size(), 2u);
  EXPECT_FALSE(f.connections[0].once);
  EXPECT_TRUE(f.connections[1].once);
  EXPECT_EQ(f.activate, (std::vector<std::string>{"src", "sink"}));
}

TEST(RtmSystemFile, ToYamlReadsBackToTheSameSystemQuotingWhatNeedsIt) {
  SystemFile f;
  f.path = kFile;
  f.name = "saved";
  f.naming = "127.0.0.1:2999";
  f.components = {{"src", {"/opt/rtm/bin/rtm-example-source", "--period", "2ms", "--note", "a: b, [c]"}},
                  {"sink", {"rtm-example-sink"}}};
  f.connections = {{"src.out0", "sink.in0", false}, {"src.out0", "sink.in1", true}};
  f.activate = {"src"};
  const SystemFile back = SystemFile::parse(f.to_yaml(), kFile);
  EXPECT_EQ(back.name, "saved");
  EXPECT_EQ(back.naming, f.naming);
  ASSERT_EQ(back.components.size(), 2u);
  EXPECT_EQ(back.components[0].command, f.components[0].command);
  ASSERT_EQ(back.connections.size(), 2u);
  EXPECT_EQ(back.connections[1].to, "sink.in1");
  EXPECT_TRUE(back.connections[1].once);
  EXPECT_FALSE(back.connections[0].once);
  EXPECT_EQ(back.activate, f.activate);
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

TEST(RtmSystemFile, BadConnectionTypeIsRefused) {
  EXPECT_NE(error_of("components: [{name: a, command: x}]\n"
                     "connections: [{from: a.out0, to: a.in0, type: twice}]")
                .find("neither 'once' nor 'repeated'"),
            std::string::npos);
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
