// SPDX-License-Identifier: Apache-2.0
// `rtm new component`: the project it writes, and the input it refuses before writing anything.
#include "scaffold/scaffold.h"
#include "launcher/system_file.h"

#include "rtm/data.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
using rtm::cli::PortSpec;
using rtm::cli::ScaffoldOptions;

std::string read_text(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The message of the std::invalid_argument f throws ("" when none).
std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

// Each test writes into a folder of its own, removed afterwards.
class RtmScaffold : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
    parent_ = fs::temp_directory_path() / ("rtm-scaffold-test-" + std::to_string(::getpid())) / test->name();
    fs::remove_all(parent_);
    fs::create_directories(parent_);
  }
  void TearDown() override { fs::remove_all(parent_.parent_path()); }

  ScaffoldOptions options(std::string name) const {
    ScaffoldOptions o;
    o.name = std::move(name);
    o.parent = parent_;
    return o;
  }

  // The message of the std::invalid_argument scaffold_component throws ("" when none).
  std::string refusal(const ScaffoldOptions& o) const {
    return message_of([&] { rtm::cli::scaffold_component(o); });
  }

  bool parent_is_empty() const { return fs::is_empty(parent_); }

  fs::path parent_;
};

TEST_F(RtmScaffold, WritesTheProjectFilesIntoParentSlashName) {
  const auto written = rtm::cli::scaffold_component(options("gripper_ctl"));
  const fs::path folder = parent_ / "gripper_ctl";
  const std::vector<fs::path> expected = {
      folder / "CMakeLists.txt",         folder / "include/gripper_ctl/gripper_ctl.h",
      folder / "src/gripper_ctl.cpp",    folder / "src/main.cpp",
      folder / "test/gripper_ctl_test.cpp", folder / "gripper_ctl.yaml",
      folder / "README.md",              folder / ".gitignore"};
  EXPECT_EQ(written, expected);
  for (const auto& file : expected) EXPECT_GT(fs::file_size(file), 0u) << file;
}

TEST_F(RtmScaffold, DeclaresEveryPortInTheClassWithItsTypeAndMovesItThroughStep) {
  auto o = options("gripper_ctl");
  o.in = {{"wrench", "RTM::TimedFloat6"}, {"width", "TimedFloat"}};
  o.out = {{"twist", "TimedFloat6"}, {"closed", "TimedBoolean"}};
  rtm::cli::scaffold_component(o);
  const fs::path folder = parent_ / "gripper_ctl";
  const auto header = read_text(folder / "include/gripper_ctl/gripper_ctl.h");
  EXPECT_NE(header.find("class GripperCtl final : public rtm::Component"), std::string::npos);
  EXPECT_NE(header.find("static Outputs step(const Inputs& in, State& state, const RTM::Time& now);"),
            std::string::npos);
  EXPECT_NE(header.find("struct State {};"), std::string::npos) << "a place for what step() remembers";
  EXPECT_NE(header.find("State state_{};"), std::string::npos);
  EXPECT_NE(header.find("add_in_port<RTM::TimedFloat6>(\"wrench\""), std::string::npos);
  EXPECT_NE(header.find("add_in_port<RTM::TimedFloat>(\"width\""), std::string::npos);
  EXPECT_NE(header.find("add_out_port<RTM::TimedFloat6>(\"twist\""), std::string::npos);
  EXPECT_NE(header.find("add_out_port<RTM::TimedBoolean>(\"closed\""), std::string::npos);
  EXPECT_NE(header.find("RTM::TimedFloat6 wrench{};"), std::string::npos);
  EXPECT_NE(header.find("RTM::TimedBoolean closed{};"), std::string::npos);

  const auto source = read_text(folder / "src/gripper_ctl.cpp");
  EXPECT_NE(source.find("out.twist = in.wrench;"), std::string::npos) << source;  // same type: passed on
  EXPECT_NE(source.find("out.closed.tm = now;"), std::string::npos) << source;    // no InPort of its type
  EXPECT_NE(source.find("wrench_in_.read(inputs_.wrench)"), std::string::npos);
  EXPECT_NE(source.find("step(inputs_, state_, rtm::now())"), std::string::npos) << source;
  EXPECT_NE(source.find("void GripperCtl::on_start() { state_ = State{}; }"), std::string::npos) << source;
  EXPECT_NE(source.find("closed_out_.write(out.closed);"), std::string::npos);

  const auto test = read_text(folder / "test/gripper_ctl_test.cpp");
  EXPECT_NE(test.find("TEST(GripperCtlStep, OutPortsCarryTheInPortOfTheirTypeWithItsStamp)"), std::string::npos);
  EXPECT_NE(test.find("TEST(GripperCtlStep, OutPortsWithoutAnInPortOfTheirTypeCarryZerosStampedNow)"),
            std::string::npos);
  EXPECT_NE(test.find("EXPECT_FALSE(out.closed.data);"), std::string::npos) << test;
  EXPECT_NE(test.find("GripperCtl::State state;"), std::string::npos) << test;

  const auto main = read_text(folder / "src/main.cpp");
  EXPECT_NE(main.find("RTM_COMPONENT(make_component)"), std::string::npos) << main;
  EXPECT_NE(main.find(".kind = \"gripper_ctl\""), std::string::npos);
  EXPECT_NE(main.find("std::make_unique<GripperCtl>(settings.name)"), std::string::npos);
}

TEST_F(RtmScaffold, CMakeListsBuildsLogicLibraryExecutableAndTestOnRtmCore) {
  rtm::cli::scaffold_component(options("gripper_ctl"));
  const auto cmake = read_text(parent_ / "gripper_ctl/CMakeLists.txt");
  for (const char* expected :
       {"cmake_minimum_required(VERSION 3.25)", "project(gripper_ctl LANGUAGES CXX)", "set(CMAKE_CXX_STANDARD 20)",
        "find_package(RTM 0.1 REQUIRED COMPONENTS core host)", "add_library(gripper_ctl_logic STATIC src/gripper_ctl.cpp)",
        "target_link_libraries(gripper_ctl_logic PUBLIC RTM::core)",
        "rtm_add_component(rtm-gripper_ctl SOURCES src/main.cpp LIBS gripper_ctl_logic RTM::host)",
        "enable_testing()", "find_package(GTest REQUIRED)",
        "target_link_libraries(gripper_ctl_test PRIVATE gripper_ctl_logic GTest::gtest_main)",
        "add_test(NAME gripper_ctl_test COMMAND gripper_ctl_test)"}) {
    EXPECT_NE(cmake.find(expected), std::string::npos) << expected;
  }
}

TEST_F(RtmScaffold, SystemFileParsesAndStartsTheBuiltComponentWithItsPeriod) {
  auto o = options("gripper_ctl");
  o.period = "1ms";
  rtm::cli::scaffold_component(o);
  const fs::path file = parent_ / "gripper_ctl/gripper_ctl.yaml";
  const auto system = rtm::cli::SystemFile::parse(read_text(file), file);
  EXPECT_EQ(system.name, "gripper_ctl");
  ASSERT_EQ(system.components.size(), 1u);
  EXPECT_EQ(system.components[0].name, "gripper_ctl0");
  EXPECT_EQ(system.components[0].command,
            (std::vector<std::string>{"build/bin/rtm-gripper_ctl", "--period", "1ms"}));
  EXPECT_TRUE(system.connections.empty());
  EXPECT_EQ(system.activate, (std::vector<std::string>{"gripper_ctl0"}));
}

TEST_F(RtmScaffold, DefaultPortsAreIn0AndOut0OfTimedFloat6WhenNoneAreGiven) {
  rtm::cli::scaffold_component(options("relay"));
  const auto header = read_text(parent_ / "relay/include/relay/relay.h");
  EXPECT_NE(header.find("add_in_port<RTM::TimedFloat6>(\"in0\""), std::string::npos);
  EXPECT_NE(header.find("add_out_port<RTM::TimedFloat6>(\"out0\""), std::string::npos);
  EXPECT_EQ(header.find("add_in_port<", header.find("add_in_port<RTM::TimedFloat6>(\"in0\"") + 1), std::string::npos)
      << "one InPort only";
  EXPECT_NE(read_text(parent_ / "relay/src/relay.cpp").find("out.out0 = in.in0;"), std::string::npos);
}

TEST_F(RtmScaffold, OnlyOutPortsMakeASourceThatComputesEveryCycle) {
  auto o = options("ramp");
  o.out = {{"level", "TimedDouble"}};
  rtm::cli::scaffold_component(o);
  const auto header = read_text(parent_ / "ramp/include/ramp/ramp.h");
  EXPECT_EQ(header.find("add_in_port<"), std::string::npos);
  const auto source = read_text(parent_ / "ramp/src/ramp.cpp");
  EXPECT_NE(source.find("[[maybe_unused]] const Inputs& in"), std::string::npos) << source;
  EXPECT_EQ(source.find("ReadResult"), std::string::npos) << source;
}

TEST_F(RtmScaffold, AnExistingEmptyFolderIsFilled) {
  fs::create_directory(parent_ / "relay");
  EXPECT_EQ(rtm::cli::scaffold_component(options("relay")).size(), 8u);
}

TEST_F(RtmScaffold, MissingParentFoldersAreMade) {
  auto o = options("relay");
  o.parent = parent_ / "a/b";
  rtm::cli::scaffold_component(o);
  EXPECT_TRUE(fs::exists(parent_ / "a/b/relay/CMakeLists.txt"));
}

TEST_F(RtmScaffold, AnExistingNonEmptyFolderIsRefusedNamingItAndLeftUnchanged) {
  fs::create_directory(parent_ / "relay");
  std::ofstream(parent_ / "relay/CMakeLists.txt") << "mine\n";
  try {
    rtm::cli::scaffold_component(options("relay"));
    FAIL() << "an existing project was written into";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find((parent_ / "relay").string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("not empty"), std::string::npos) << e.what();
  }
  EXPECT_EQ(std::distance(fs::directory_iterator(parent_ / "relay"), fs::directory_iterator()), 1);
  EXPECT_EQ(read_text(parent_ / "relay/CMakeLists.txt"), "mine\n");
}

TEST_F(RtmScaffold, AFileWhereTheFolderWouldGoIsRefusedAndLeftUnchanged) {
  std::ofstream(parent_ / "relay") << "a file\n";
  EXPECT_THROW(rtm::cli::scaffold_component(options("relay")), std::runtime_error);
  EXPECT_EQ(read_text(parent_ / "relay"), "a file\n");
}

TEST_F(RtmScaffold, BadComponentNamesAreRefusedNamingThemAndNothingIsWritten) {
  for (const std::string name : {"", "Gripper", "gripper-ctl", "1gripper", "gripper__ctl", "gripper_", "_gripper",
                                 "a_b", "inputs", "outputs", "../gripper", "gripper ctl",
                                 "a_name_that_is_much_too_long_for_a_component"}) {
    const auto message = refusal(options(name));
    EXPECT_NE(message.find("'" + name + "'"), std::string::npos) << name << ": " << message;
  }
  EXPECT_TRUE(parent_is_empty());
}

TEST_F(RtmScaffold, BadPortNamesAreRefusedNamingThemAndNothingIsWritten) {
  for (const std::string name : {"", "Wrench", "1wrench", "wrench-in", "wrench_", "wr__ench", "class", "errno"}) {
    auto o = options("relay");
    o.in = {{name, "TimedFloat6"}};
    const auto message = refusal(o);
    EXPECT_NE(message.find("'" + name + "'"), std::string::npos) << name << ": " << message;
  }
  EXPECT_TRUE(parent_is_empty());
}

TEST_F(RtmScaffold, UnknownPortTypesAreRefusedNamingThemAndListingTheKnownOnes) {
  auto o = options("relay");
  o.out = {{"force", "TimedFloat7"}};
  const auto message = refusal(o);
  EXPECT_NE(message.find("'TimedFloat7'"), std::string::npos) << message;
  EXPECT_NE(message.find("TimedFloatSeq"), std::string::npos) << message;
  EXPECT_TRUE(parent_is_empty());
}

TEST_F(RtmScaffold, DuplicatePortNamesAreRefusedInAndOutAlike) {
  auto o = options("relay");
  o.in = {{"wrench", "TimedFloat6"}, {"wrench", "TimedFloat"}};
  EXPECT_NE(refusal(o).find("'wrench' is given twice"), std::string::npos) << refusal(o);
  o.in = {{"wrench", "TimedFloat6"}};
  o.out = {{"wrench", "TimedFloat6"}};
  EXPECT_NE(refusal(o).find("'wrench' is given twice"), std::string::npos) << refusal(o);
  EXPECT_TRUE(parent_is_empty());
}

TEST_F(RtmScaffold, PortNamesThatWouldHideAnotherPortsIndexAliasAreRefused) {
  auto o = options("relay");
  o.in = {{"in1", "TimedFloat6"}};  // InPort 0 called in1: `rtm get relay0.in1` would find it
  EXPECT_NE(refusal(o).find("'in1'"), std::string::npos) << refusal(o);
  o.in = {{"wrench", "TimedFloat6"}};
  o.out = {{"in0", "TimedFloat6"}};
  EXPECT_NE(refusal(o).find("'in0'"), std::string::npos) << refusal(o);
  o.out = {{"out0", "TimedFloat6"}};  // its own alias: fine
  EXPECT_EQ(refusal(o), "");
}

TEST_F(RtmScaffold, TheDescriptionLeadsTheHelpLineWithItsQuotesEscapedAndNoTodoIsLeft) {
  auto o = options("gripper_ctl");
  o.description = R"(closes the "gripper" \ gently.)";
  rtm::cli::scaffold_component(o);
  const std::string main_cpp = read_text(parent_ / "gripper_ctl" / "src" / "main.cpp");
  EXPECT_NE(main_cpp.find(R"("rtm-gripper_ctl: closes the \"gripper\" \\ gently. InPorts: in0)"), std::string::npos)
      << main_cpp;
  EXPECT_EQ(main_cpp.find("TODO"), std::string::npos) << main_cpp;
  const std::string header = read_text(parent_ / "gripper_ctl" / "include" / "gripper_ctl" / "gripper_ctl.h");
  EXPECT_EQ(header.find("TODO"), std::string::npos) << header;
  EXPECT_NE(header.find(R"(add_in_port<RTM::TimedFloat6>("in0", {"the RTM::TimedFloat6 it reads", {}}))"),
            std::string::npos)
      << "what rtm cat says of a port until its author says more: " << header;

  auto plain = options("plain_ctl");
  rtm::cli::scaffold_component(plain);
  EXPECT_NE(read_text(parent_ / "plain_ctl" / "src" / "main.cpp").find(R"("rtm-plain_ctl: InPorts: in0)"),
            std::string::npos)
      << "without a description, the ports alone";
}

TEST_F(RtmScaffold, ADescriptionOfMoreThanOneLineOrTooLongIsRefusedAndNothingIsWritten) {
  auto o = options("gripper_ctl");
  o.description = "two\nlines";
  EXPECT_NE(refusal(o).find("control character"), std::string::npos) << refusal(o);
  o.description = std::string(301, 'x');
  EXPECT_NE(refusal(o).find("at most 300"), std::string::npos) << refusal(o);
  EXPECT_TRUE(parent_is_empty());
}

TEST_F(RtmScaffold, AParameterIsOneParamLineThatStepTheRunnerAndTheTestAllUse) {
  auto o = options("lowpass");
  o.params = {rtm::cli::parse_param_spec("cutoff_hz:Hz:10:the filter's cut-off"),
              rtm::cli::parse_param_spec("gain::0.5")};
  rtm::cli::scaffold_component(o);
  const fs::path project = parent_ / "lowpass";
  const std::string header = read_text(project / "include" / "lowpass" / "lowpass.h");
  EXPECT_NE(header.find(R"(rtm::Param<float> cutoff_hz{10.0f, {"cutoff_hz", "Hz", "the filter's cut-off", )"
                        "rtm::ParameterAccess::live}};"),
            std::string::npos)
      << header;
  EXPECT_NE(header.find(R"(rtm::Param<float> gain{0.5f, {"gain", "", "gain", rtm::ParameterAccess::live}};)"),
            std::string::npos)
      << header;
  EXPECT_NE(header.find("static Outputs step(const Inputs& in, const Params& params, State& state, const RTM::Time& now);"),
            std::string::npos)
      << header;
  const std::string source = read_text(project / "src" / "lowpass.cpp");
  EXPECT_NE(source.find("params_live_.take(params_);"), std::string::npos) << source;
  EXPECT_NE(source.find("add_parameters(parameters(), params_live_);"), std::string::npos) << source;
  EXPECT_NE(source.find("step(inputs_, params_, state_, rtm::now())"), std::string::npos) << source;
  const std::string main_cpp = read_text(project / "src" / "main.cpp");
  EXPECT_NE(main_cpp.find("rtm::add_parameter_options(app, Lowpass::parameters(), *params)"), std::string::npos)
      << main_cpp;
  EXPECT_NE(read_text(project / "test" / "lowpass_test.cpp").find("Lowpass::step(in, Lowpass::Params{}, state, stamp(7, 250))"),
            std::string::npos);
}

TEST(RtmScaffoldParamSpec, BadSpecsAreRefusedNamingTheText) {
  const auto refusal = [](std::string_view text) { return message_of([&] { rtm::cli::parse_param_spec(text); }); };
  EXPECT_NE(refusal("gain").find("write name:unit:default"), std::string::npos);
  EXPECT_NE(refusal("gain:1/N:abc").find("the default 'abc' is not a number"), std::string::npos);
  EXPECT_NE(refusal("gain:1/N:nan").find("finite"), std::string::npos);
  EXPECT_NE(refusal("Gain:1/N:1").find("parameter 'Gain'"), std::string::npos);
  EXPECT_NE(refusal("gain:\"N:1").find("a quote, a backslash or a control character"), std::string::npos);
  EXPECT_EQ(rtm::cli::parse_param_spec("k:N/m:2e3:a: b").description, "a: b") << "the rest is the description";
  EXPECT_EQ(rtm::cli::parse_param_spec("k:N/m:2e3").default_value, 2000.0);
}

// An IDL file of the test's, in the test's folder (not the project's).
fs::path write_idl(const fs::path& folder, const std::string& name, const std::string& text) {
  fs::create_directories(folder);
  std::ofstream(folder / name) << text;
  return folder / name;
}

constexpr const char* kPoseIdl = R"(// poses /* with a comment */
#include "RTM.idl"
module My {
  struct Position { double x; double y; double z; };
  struct TimedPose { RTM::Time tm; Position p; double q[4]; };
  module Arm { struct TimedGrip { RTM::Time tm; float width; }; };
};
struct Untimed { double a; };
)";

TEST_F(RtmScaffold, APortOfATypeOfYourOwnIdlCopiesTheFileAndCompilesItsTypesForTheComponent) {
  auto o = options("tracker");
  o.in = {{"pose", "My::TimedPose"}, {"wrench", "TimedFloat6"}};
  o.out = {{"filtered", "My::TimedPose"}, {"grip", "My::Arm::TimedGrip"}};
  o.idl = {write_idl(parent_ / "types", "Poses.idl", kPoseIdl)};
  const auto written = rtm::cli::scaffold_component(o);
  const fs::path project = parent_ / "tracker";
  EXPECT_NE(std::find(written.begin(), written.end(), project / "idl/Poses.idl"), written.end());
  EXPECT_EQ(read_text(project / "idl/Poses.idl"), kPoseIdl);
  const std::string cmake = read_text(project / "CMakeLists.txt");
  EXPECT_NE(cmake.find("rtm_add_idl(tracker_types FILES idl/Poses.idl TYPES My::TimedPose My::Arm::TimedGrip)"),
            std::string::npos)
      << cmake;
  EXPECT_NE(cmake.find("target_link_libraries(tracker_logic PUBLIC RTM::core tracker_types)"), std::string::npos)
      << cmake;
  const std::string header = read_text(project / "include/tracker/tracker.h");
  EXPECT_NE(header.find("#include \"tracker_types.h\""), std::string::npos) << header;
  EXPECT_NE(header.find("rtm::InPort<My::TimedPose>& pose_in_"), std::string::npos) << header;
  EXPECT_NE(header.find("My::Arm::TimedGrip grip{};"), std::string::npos) << header;
  const std::string source = read_text(project / "src/tracker.cpp");
  EXPECT_NE(source.find("out.filtered = in.pose;"), std::string::npos) << "same type: passed on: " << source;
  EXPECT_NE(source.find("out.grip.tm = now;"), std::string::npos) << source;
  const std::string test = read_text(project / "test/tracker_test.cpp");
  EXPECT_NE(test.find("in.pose.tm = stamp(101, 500);"), std::string::npos) << test;
  EXPECT_NE(test.find("EXPECT_EQ(out.filtered.tm.sec, 101u);"), std::string::npos) << test;
  EXPECT_NE(test.find("EXPECT_EQ(out.grip.tm.sec, 7u);"), std::string::npos) << test;
}

TEST_F(RtmScaffold, APortOfAPackagesTypeFindsThePackageAndIncludesItsHeader) {
  auto o = options("tracker");
  o.in = {{"pose", "My::TimedPose"}};
  o.type_packages = {"pose_types", "pose_types"};
  rtm::cli::scaffold_component(o);
  const fs::path project = parent_ / "tracker";
  const std::string cmake = read_text(project / "CMakeLists.txt");
  EXPECT_NE(cmake.find("find_package(pose_types REQUIRED)"), std::string::npos) << cmake;
  EXPECT_EQ(cmake.find("rtm_add_idl(tracker"), std::string::npos) << cmake;
  EXPECT_NE(cmake.find("PUBLIC RTM::core pose_types::pose_types)"), std::string::npos) << "once: " << cmake;
  EXPECT_NE(read_text(project / "include/tracker/tracker.h").find("#include <pose_types.h>"), std::string::npos);
  EXPECT_FALSE(fs::exists(project / "idl"));
}

TEST_F(RtmScaffold, ATypeOfYourOwnThatNoFileDeclaresAsATimedStructIsRefusedAndNothingIsWritten) {
  const fs::path idl = write_idl(parent_.parent_path() / "types", "Poses.idl", kPoseIdl);
  auto o = options("tracker");
  o.in = {{"pose", "My::TimedPose"}};
  EXPECT_NE(refusal(o).find("My::TimedPose is a type of your own: name the IDL file that declares it (--idl FILE)"),
            std::string::npos)
      << refusal(o);
  o.idl = {idl};
  o.in = {{"pose", "My::TimedPos"}};
  EXPECT_NE(refusal(o).find("port 'pose': My::TimedPos: no struct of that name in Poses.idl"), std::string::npos)
      << refusal(o);
  o.in = {{"pose", "Position::TimedPose"}};  // a module per '::'
  EXPECT_NE(refusal(o).find("no struct of that name"), std::string::npos) << refusal(o);
  o.in = {{"p", "My::Position"}};
  EXPECT_NE(refusal(o).find("is declared in Poses.idl but is not timed"), std::string::npos) << refusal(o);
  o.in = {{"pose", "My::TimedPose"}};
  o.idl = {idl, idl};
  EXPECT_NE(refusal(o).find("two files are called Poses.idl"), std::string::npos) << refusal(o);
  o.idl = {parent_.parent_path() / "types" / "missing.idl"};
  EXPECT_NE(refusal(o).find("missing.idl"), std::string::npos) << refusal(o);
  o.idl = {write_idl(parent_.parent_path() / "types", "bad-name.idl", kPoseIdl)};
  EXPECT_NE(refusal(o).find("name an IDL file <name>.idl"), std::string::npos) << refusal(o);
  o.idl = {};
  o.type_packages = {"pose-types"};
  EXPECT_NE(refusal(o).find("--types 'pose-types'"), std::string::npos) << refusal(o);
  EXPECT_TRUE(parent_is_empty());
}

TEST_F(RtmScaffold, ABadPeriodIsRefusedNamingIt) {
  auto o = options("relay");
  o.period = "2 fortnights";
  EXPECT_NE(refusal(o).find("'2 fortnights'"), std::string::npos) << refusal(o);
  o.period = "10us";  // under the runner's 50 us
  EXPECT_NE(refusal(o).find("'10us'"), std::string::npos) << refusal(o);
  EXPECT_TRUE(parent_is_empty());
}

TEST_F(RtmScaffold, APythonComponentIsItsClassATestOfItsLogicAndASystemFileThatRunsIt) {
  auto o = options("gripper_ctl");
  o.python = true;
  o.in = {{"wrench", "RTM::TimedFloat6"}, {"level", "RTM::TimedDouble"}};
  o.out = {{"grip", "RTM::TimedFloat6"}, {"flags", "RTM::TimedLong"}};
  o.params = {{"cutoff_hz", "Hz", 10, "the filter's cut-off"}};
  o.description = R"(grips "gently")";
  const auto written = rtm::cli::scaffold_component(o);
  const fs::path folder = parent_ / "gripper_ctl";
  EXPECT_EQ(written, (std::vector<fs::path>{folder / "gripper_ctl.py", folder / "test_gripper_ctl.py",
                                            folder / "gripper_ctl.yaml", folder / "README.md", folder / ".gitignore"}));
  EXPECT_NE(fs::status(folder / "gripper_ctl.py").permissions() & fs::perms::owner_exec, fs::perms::none)
      << "the system file runs it as a program";
  const std::string code = read_text(folder / "gripper_ctl.py");
  EXPECT_EQ(code.rfind("#!/usr/bin/python3\n", 0), 0u) << "Debian's python3, whose numpy rtm uses";
  for (const char* line : {"class GripperCtl(rtm.Component):", "    kind = \"gripper_ctl\"",
                           R"(    description = "grips \"gently\"")",
                           R"(        "wrench": rtm.In("TimedFloat6", "the RTM::TimedFloat6 it reads"),)",
                           R"(        "flags": rtm.Out("TimedLong", "the RTM::TimedLong it writes"),)",
                           R"(        "cutoff_hz": rtm.Parameter(10.0, unit="Hz", description="the filter's cut-off"),)",
                           R"(        outputs["grip"] = inputs["wrench"]  # passed on as it came: the logic goes here)",
                           R"(    # outputs["flags"] = ...  (RTM::TimedLong: one value))", "def compute(inputs, params):",
                           "        for name, values in compute(inputs, params).items():", "    rtm.run(GripperCtl)"})
    EXPECT_NE(code.find(line), std::string::npos) << line << "\n" << code;
  const std::string test = read_text(folder / "test_gripper_ctl.py");
  EXPECT_NE(test.find(R"(PARAMS = {"cutoff_hz": 10.0})"), std::string::npos) << test;
  EXPECT_NE(test.find(R"(compute({"wrench": None, "level": None}, PARAMS) == {})"), std::string::npos) << test;
  EXPECT_NE(test.find(R"(np.testing.assert_array_equal(outputs["grip"], inputs["wrench"]))"), std::string::npos) << test;
  const auto system = rtm::cli::SystemFile::load(folder / "gripper_ctl.yaml");
  ASSERT_EQ(system.components.size(), 1u);
  EXPECT_EQ(system.components[0].command, (std::vector<std::string>{"./gripper_ctl.py", "--period", "2ms"}));
}

TEST_F(RtmScaffold, APythonComponentTakesTheBuiltInTypesOnly) {
  auto o = options("posed");
  o.python = true;
  o.in = {{"pose", "My::TimedPose"}};
  EXPECT_NE(refusal(o).find("port 'pose': a component in Python takes the built-in types only (TimedFloat6"),
            std::string::npos)
      << refusal(o);
  o.in = {};
  o.type_packages = {"my_types"};
  EXPECT_NE(refusal(o).find("--idl and --types: a component in Python takes the built-in types only"), std::string::npos)
      << refusal(o);
  EXPECT_TRUE(parent_is_empty());
}

TEST(RtmScaffoldPortSpec, TakesTheTypeWithOrWithoutTheRtmModule) {
  const PortSpec bare = rtm::cli::parse_port_spec("wrench:TimedFloat6");
  EXPECT_EQ(bare.name, "wrench");
  EXPECT_EQ(bare.type, "RTM::TimedFloat6");
  const PortSpec full = rtm::cli::parse_port_spec("gains:RTM::TimedDoubleSeq");
  EXPECT_EQ(full.name, "gains");
  EXPECT_EQ(full.type, "RTM::TimedDoubleSeq");
}

TEST(RtmScaffoldPortSpec, ATypeOfYourOwnIsAModuleAndAName) {
  EXPECT_EQ(rtm::cli::parse_port_spec("pose:My::TimedPose").type, "My::TimedPose");
  EXPECT_EQ(rtm::cli::parse_port_spec("grip:Lab::Arm::TimedGrip").type, "Lab::Arm::TimedGrip");
  const auto message = [](std::string_view text) { return message_of([&] { rtm::cli::parse_port_spec(text); }); };
  EXPECT_NE(message("pose:RTM::TimedPose").find("'RTM::TimedPose' is not a port type"), std::string::npos)
      << "RTM's module holds the built-in types only: " << message("pose:RTM::TimedPose");
  EXPECT_NE(message("pose:My::").find("Module::Type"), std::string::npos) << message("pose:My::");
  EXPECT_NE(message("pose:My::Timed-Pose").find("Module::Type"), std::string::npos);
}

TEST(RtmScaffoldPortSpec, BadSpecsAreRefusedNamingTheText) {
  const auto message = [](std::string_view text) { return message_of([&] { rtm::cli::parse_port_spec(text); }); };
  EXPECT_NE(message("wrench").find("'wrench' has no type"), std::string::npos) << message("wrench");
  EXPECT_NE(message(":TimedFloat6").find("':TimedFloat6'"), std::string::npos) << message(":TimedFloat6");
  EXPECT_NE(message("Wrench:TimedFloat6").find("'Wrench:TimedFloat6'"), std::string::npos);
  EXPECT_NE(message("wrench:Float6").find("'Float6' is not a port type"), std::string::npos)
      << message("wrench:Float6");
  EXPECT_NE(message("wrench:timedfloat6").find("did you mean TimedFloat6?"), std::string::npos)
      << message("wrench:timedfloat6");
}

TEST(RtmScaffoldPortSpec, KnownTypesAreTheTypesRtmDataGivesDataTraits) {
  const std::vector<std::string> traits = {
      std::string(rtm::DataTraits<RTM::TimedFloat6>::name),    std::string(rtm::DataTraits<RTM::TimedFloat>::name),
      std::string(rtm::DataTraits<RTM::TimedDouble>::name),    std::string(rtm::DataTraits<RTM::TimedLong>::name),
      std::string(rtm::DataTraits<RTM::TimedBoolean>::name),   std::string(rtm::DataTraits<RTM::TimedFloat3>::name),
      std::string(rtm::DataTraits<RTM::TimedFloatSeq>::name),
      std::string(rtm::DataTraits<RTM::TimedDoubleSeq>::name)};
  EXPECT_EQ(rtm::cli::known_port_types(), traits);
}

TEST(RtmScaffoldNames, TheClassIsTheWordsCapitalised) {
  EXPECT_EQ(rtm::cli::class_name_of("gripper_ctl"), "GripperCtl");
  EXPECT_EQ(rtm::cli::class_name_of("relay"), "Relay");
  EXPECT_EQ(rtm::cli::class_name_of("arm2_joint_ctl"), "Arm2JointCtl");
}

}  // namespace
