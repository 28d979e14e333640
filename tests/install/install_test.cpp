// SPDX-License-Identifier: Apache-2.0
// RTM as others build on it: `cmake --install` into a temporary prefix, then projects outside
// this tree built against that prefix alone (find_package(RTM)), run with a real omniNames and
// wired by the installed `rtm`.
#include "rtm_test/run_command.h"

#include "rtm_test/child_process.h"
#include "rtm_test/eventually.h"
#include "rtm_test/omni_names.h"

#include <gtest/gtest.h>
#include <httplib.h>
#include <nlohmann/json.hpp>

#include <signal.h>
#include <unistd.h>

#include <cctype>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <thread>

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using rtm_test::ChildProcess;
using rtm_test::CommandResult;
using rtm_test::eventually;
using namespace std::chrono_literals;

const fs::path kSource = RTM_SOURCE_DIR;
const fs::path kBuild = RTM_BUILD_DIR;

std::string read_file(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class Installed : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = fs::temp_directory_path() / ("rtm-install-" + std::to_string(::getpid()));
    fs::remove_all(root_);
    fs::create_directories(root_);
    const CommandResult r =
        rtm_test::run_command({CMAKE_COMMAND, "--install", kBuild.string(), "--prefix", prefix().string()}, {}, 300s);
    install_log_ = r.out + r.err;
    installed_ = r.exit_code == 0;
  }
  static void TearDownTestSuite() { fs::remove_all(root_); }
  void SetUp() override { ASSERT_TRUE(installed_) << install_log_; }

  static fs::path prefix() { return root_ / "usr"; }
  static fs::path bin(const std::string& program) { return prefix() / "bin" / program; }

  // Copies a project folder out of the tree and builds it against the prefix alone.
  static fs::path build_project(const fs::path& project, const std::string& as) {
    const fs::path source = root_ / as;
    fs::copy(project, source, fs::copy_options::recursive);
    return build_in_place(source, root_ / (as + "-build"), prefix().string());
  }
  // Builds the project in source against the prefixes (a CMake list).
  static fs::path build_in_place(const fs::path& source, const fs::path& build, const std::string& prefixes) {
    CommandResult r = rtm_test::run_command({CMAKE_COMMAND, "-S", source.string(), "-B", build.string(),
                                             "-DCMAKE_PREFIX_PATH=" + prefixes,
                                             "-DCMAKE_EXPORT_COMPILE_COMMANDS=ON", "-DCMAKE_BUILD_TYPE=Release"},
                                            {"CMAKE_PREFIX_PATH=", "RTM_DIR="}, 300s);
    EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
    r = rtm_test::run_command({CMAKE_COMMAND, "--build", build.string(), "-j2"}, {}, 600s);
    EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
    return build;
  }

  CommandResult rtm(std::vector<std::string> args) {
    args.insert(args.begin(), {bin("rtm").string(), "--naming", names_.address()});
    return rtm_test::run_command(args, {"RTM_TLS="});
  }
  ChildProcess& start(const fs::path& program, const std::string& name, std::vector<std::string> extra = {}) {
    std::vector<std::string> argv{program.string(), "--name", name, "--naming", names_.address()};
    argv.insert(argv.end(), extra.begin(), extra.end());
    return rtm_test::start_bound(started_, argv);
  }
  std::uint64_t accepted(const std::string& component, const std::string& port) {
    const CommandResult r = rtm({"--json", "cat", component});
    last_cat_ = r.out + r.err;
    if (r.exit_code != 0) return 0;
    const json described = json::parse(r.out);
    for (const auto& p : described["ports"])
      if (p["name"] == port) return p["counters"]["accepted"].get<std::uint64_t>();
    return 0;
  }
  std::uint64_t wait_for_data(const std::string& component, const std::string& port) {
    std::uint64_t n = 0;
    eventually([&] { return (n = accepted(component, port)) != 0; });
    return n;
  }

  // What the installed rtm serve's page saves as a system file of this name (its YAML).
  std::string save_from_the_page(const std::string& name) {
    ChildProcess::Options options;
    options.echo_output = false;
    options.extra_env = {"RTM_TLS="};
    ChildProcess serve({bin("rtm").string(), "--naming", names_.address(), "serve"}, options);
    const std::string line = serve.wait_for_line("http://");  // http://127.0.0.1:<port>/#token=<hex>
    const auto slash = line.find("/#token=");
    const auto colon = line.rfind(':', slash);
    if (slash == std::string::npos || colon == std::string::npos) return "no URL in: " + line;
    std::string token = line.substr(slash + 8);
    while (!token.empty() && std::isspace(static_cast<unsigned char>(token.back()))) token.pop_back();
    httplib::Client client("127.0.0.1", std::stoi(line.substr(colon + 1, slash - colon - 1)));
    client.set_read_timeout(10, 0);
    const auto r = client.Get(("/api/system-file?name=" + name).c_str(), {{"X-RTM-Token", token}});
    if (!r || r->status != 200) return "the save failed: " + (r ? r->body : httplib::to_string(r.error()));
    return json::parse(r->body)["yaml"].get<std::string>();
  }

  static inline fs::path root_;
  static inline bool installed_ = false;
  static inline std::string install_log_;
  rtm_test::OmniNames names_;
  std::vector<std::unique_ptr<ChildProcess>> started_;
  std::string last_cat_;  // what the last `rtm cat` said, for a failure's message
};

TEST_F(Installed, TheGnuLayoutHoldsProgramsLibrariesHeadersIdlModelsTemplatesAndThePackage) {
  for (const char* file : {"bin/rtm", "bin/rtm-controller", "bin/rtm-servo", "bin/pa10-sim",
                           "lib/cmake/RTM/RTMConfig.cmake", "lib/cmake/RTM/RTMConfigVersion.cmake",
                           "lib/cmake/RTM/RTMTargets.cmake", "lib/cmake/RTM/RtmIdl.cmake",
                           "include/rtm/rtm/component.h", "include/rtm/rt/activity.h", "include/rtm/arm/can/bus.h",
                           "include/rtm/idl/RTM.hh", "include/rtm/idl/RTMExt.hh", "share/rtm/idl/RTM.idl",
                           "share/rtm/models/pa10_scene.xml", "share/rtm/models/pa10.urdf", "share/rtm/scaffold/component.h.in",
                           "share/bash-completion/completions/rtm", "share/doc/rtm/README.md",
                           "share/doc/rtm/system-files.md", "bin/rtm-example-source", "bin/rtm-example-sink",
                           "share/rtm/examples/source_sink/system.yaml", "share/rtm/examples/source_sink/source.cpp",
                           "share/rtm/examples/force-servo/demo", "share/rtm/examples/force-servo/system.yaml",
                           "share/rtm/examples/force-servo/operator_profile.yaml", "share/rtm/tools/wakeup_witness.py",
                           "bin/rtm-container", "lib/rtm/modules/rtm-controller.so", "lib/rtm/modules/rtm-actuator.so",
                           "lib/rtm/modules/rtm-sensor.so", "lib/rtm/modules/rtm-joystick.so"})
    EXPECT_TRUE(fs::exists(prefix() / file)) << file;
  // The core's libraries: shared by default (RTM_SHARED_LIBS), static archives otherwise.
  const bool shared = fs::exists(prefix() / "lib/librtm_core.so");
  EXPECT_TRUE(shared || fs::exists(prefix() / "lib/librtm_core.a")) << "no librtm_core";
  if (shared) {
    for (const char* lib : {"rt", "idl", "core", "host"}) {
      EXPECT_TRUE(fs::exists(prefix() / "lib" / std::string("librtm_").append(lib).append(".so"))) << lib;
    }
  }
}

TEST_F(Installed, NoInstalledFileNamesTheSourceOrBuildTree) {
  std::size_t files = 0;
  for (const auto& entry : fs::recursive_directory_iterator(prefix())) {
    if (!entry.is_regular_file()) continue;
    ++files;
    const std::string text = read_file(entry.path());
    EXPECT_EQ(text.find(kSource.string()), std::string::npos) << entry.path() << " names " << kSource;
    EXPECT_EQ(text.find(kBuild.string()), std::string::npos) << entry.path() << " names " << kBuild;
  }
  EXPECT_GT(files, 50u);
}

TEST_F(Installed, TheTreeMovesPa10SimFindsItsSceneBesideItselfWherever) {
  const fs::path moved = root_ / "moved";
  fs::create_directories(moved);
  const CommandResult copy = rtm_test::run_command({"/bin/cp", "-a", prefix().string(), moved.string()});
  ASSERT_EQ(copy.exit_code, 0) << copy.err;
  const CommandResult help = rtm_test::run_command({(moved / "usr/bin/pa10-sim").string(), "--help"});
  EXPECT_EQ(help.exit_code, 0) << help.err;
  EXPECT_NE(help.out.find((moved / "usr/share/rtm/models/pa10_scene.xml").string()), std::string::npos) << help.out;
  fs::remove_all(moved);
}

// The installed rtm-container, moved elsewhere, loads the installed modules beside it (and they
// the shared libraries): two controllers in one process, wired in-process.
TEST_F(Installed, TheInstalledContainerMovedElsewhereRunsTheInstalledModulesWiredInProcess) {
  const fs::path moved = root_ / "moved-container";
  fs::create_directories(moved);
  const CommandResult copy = rtm_test::run_command({"/bin/cp", "-a", prefix().string(), moved.string()});
  ASSERT_EQ(copy.exit_code, 0) << copy.err;
  ChildProcess::Options options;
  options.echo_output = false;
  options.extra_env = {"RTM_TLS=", "RTM_MODULE_PATH="};
  ChildProcess container({(moved / "usr/bin/rtm-container").string(), "--name", "cell0", "--naming", names_.address(),
                          "--", "c1", "rtm-controller", "--", "c2", "rtm-controller", "--period", "5ms"},
                         options);
  container.wait_for_line("2 members up");
  const CommandResult connected = rtm({"connect", "c1.twist", "c2.wrench"});
  ASSERT_EQ(connected.exit_code, 0) << connected.err;
  const CommandResult described = rtm({"--json", "cat", "c1"});
  ASSERT_EQ(described.exit_code, 0) << described.err;
  const json c1 = json::parse(described.out);
  bool in_process = false;
  for (const auto& p : c1["ports"])
    if (p["name"] == "twist") in_process = p["subscriptions"].at(0)["in_process"].get<bool>();
  EXPECT_TRUE(in_process) << described.out;
  container.send_signal(SIGTERM);
  const auto status = container.wait_for_exit(10s);
  ASSERT_TRUE(status.has_value());
  EXPECT_EQ(status->code, 0) << container.output();
  fs::remove_all(moved);
}

// The installed Python package, moved elsewhere with the tree, imports with PYTHONPATH alone
// (its module finds RTM's libraries beside it) and reaches an installed component.
TEST_F(Installed, TheInstalledPythonPackageMovedElsewhereImportsAndDescribesAnInstalledComponent) {
  const fs::path package = "lib/python3/dist-packages/rtm/__init__.py";
  if (!fs::exists(kBuild / "python/rtm/__init__.py")) GTEST_SKIP() << "built without RTM_WITH_PYTHON";
  ASSERT_TRUE(fs::exists(prefix() / package)) << package;
  const fs::path moved = root_ / "moved-python";
  fs::create_directories(moved);
  const CommandResult copy = rtm_test::run_command({"/bin/cp", "-a", prefix().string(), moved.string()});
  ASSERT_EQ(copy.exit_code, 0) << copy.err;
  ChildProcess::Options options;
  options.echo_output = false;
  options.extra_env = {"RTM_TLS="};
  ChildProcess controller({(moved / "usr/bin/rtm-controller").string(), "--name", "pyc0", "--naming", names_.address()},
                          options);
  const std::string script =
      "import rtm, sys, time\n"
      "s = rtm.System(naming=sys.argv[1])\n"
      "end = time.monotonic() + 10\n"
      "while 'pyc0' not in s.components() and time.monotonic() < end:\n"
      "    time.sleep(0.05)\n"
      "d = s.describe('pyc0')\n"
      "print(d['kind'], [(p['name'], p['type']) for p in d['ports']])\n";
  const CommandResult r = rtm_test::run_command(
      {"/usr/bin/python3", "-c", script, names_.address()},
      {"PYTHONPATH=" + (moved / "usr/lib/python3/dist-packages").string(), "RTM_TLS="}, 30s);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "controller [('wrench', 'RTM::TimedFloat6'), ('reference', 'RTM::TimedFloat6'), "
                   "('twist', 'RTM::TimedFloat6')]\n")
      << r.err;
  controller.send_signal(SIGTERM);
  EXPECT_TRUE(controller.wait_for_exit(10s).has_value());
  fs::remove_all(moved);
}

TEST_F(Installed, TheSourceSinkExampleBuildsAgainstThePrefixAloneAndRunsWiredByTheInstalledRtm) {
  const fs::path build = build_project(kSource / "examples/source_sink", "source_sink");
  const std::string commands = read_file(build / "compile_commands.json");
  ASSERT_FALSE(commands.empty());
  EXPECT_EQ(commands.find(kBuild.string()), std::string::npos) << "an include path into the build tree";
  EXPECT_EQ(commands.find((kSource / "src").string()), std::string::npos) << "an include path into the source tree";
  start(build / "bin/rtm-example-source", "source0");
  start(build / "bin/rtm-example-sink", "sink0");
  CommandResult r = rtm({"connect", "source0.out0", "sink0.in0"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = rtm({"on", "source0", "sink0"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_GT(wait_for_data("sink0", "in0"), 0u) << last_cat_;
}

TEST_F(Installed, ACustomIdlTypeCrossesProcessesAndAMismatchIsRefusedAtConnect) {
  const fs::path build = build_project(kSource / "tests/install/custom_type", "custom_type");
  start(build / "pose-relay", "a", {"--on"});
  start(build / "pose-relay", "b");
  start(bin("rtm-controller"), "c");
  const CommandResult cat = rtm({"cat", "a"});
  EXPECT_NE(cat.out.find("My::TimedPose"), std::string::npos) << cat.out;
  CommandResult r = rtm({"connect", "a.out0", "b.in0"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_GT(wait_for_data("b", "in0"), 0u) << "a's TimedPose did not reach b: " << last_cat_;
  r = rtm({"connect", "a.out0", "c.in0"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("types differ"), std::string::npos) << r.err;
  EXPECT_EQ(accepted("c", "in0"), 0u);
}

TEST_F(Installed, ACustomIdlTypeRoundTripsThroughTheInstalledRtmPutGetAndWatch) {
  const fs::path build = build_project(kSource / "tests/install/custom_type", "custom_type");
  start(build / "pose-relay", "r", {"--on"});
  // The tool has no stubs of My::TimedPose: it reads the type from the port.
  CommandResult r = rtm({"put", "r.in0", "0.25", "-1.5", "2", "0.5", "0.5", "0.5", "0.5"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  json got;
  eventually([&] {
    r = rtm({"--json", "get", "r.out0"});
    if (r.exit_code != 0) return false;
    got = json::parse(r.out);
    return got["fields"]["p"]["x"] == 0.25;
  });
  EXPECT_EQ(got["type"], "My::TimedPose") << got.dump();
  EXPECT_EQ(got["fields"]["p"]["y"], -1.5) << got.dump();
  EXPECT_EQ(got["values"], json::parse("[0.25, -1.5, 2.0, 0.5, 0.5, 0.5, 0.5]")) << got.dump();
  r = rtm({"get", "r.out0"});
  EXPECT_NE(r.out.find("p.x=0.2500  p.y=-1.5000"), std::string::npos) << r.out;
  const fs::path csv = root_ / "pose.csv";
  r = rtm({"watch", "r.out0", "--count", "3", "--csv", csv.string()});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(read_file(csv).find("0.25"), std::string::npos) << read_file(csv);
  // Undescribed, its columns are labelled as `rtm get` labels the values: by their leaf paths.
  EXPECT_EQ(read_file(csv).rfind("time_ns,p.x,p.y,p.z,q[0],q[1],q[2],q[3]\n", 0), 0u) << read_file(csv);
  // A word that is not a number, or too few, names the member and changes nothing.
  r = rtm({"put", "r.in0", "0.25", "abc", "2", "1", "0", "0", "0"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("p.y: 'abc' is not a number"), std::string::npos) << r.err;
  r = rtm({"put", "r.in0", "1", "2"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("takes 7 values"), std::string::npos) << r.err;
  EXPECT_EQ(accepted("r", "in0"), 1u);
}

TEST_F(Installed, AScaffoldedComponentBuildsPassesItsTestRunsUnderRtmUpAndComesBackFromThePagesSaveWithItsParameter) {
  // A description with a quote and a backslash: the generated literal must still compile.
  const std::string description = R"(closes the "gripper" as the wrist is pushed \ along z)";
  // With an OutPort of a type of its own IDL, which the project gets a copy of.
  const CommandResult made = rtm_test::run_command(
      {bin("rtm").string(), "new", "component", "gripper_ctl", "--in", "wrench:TimedFloat6", "--out",
       "twist:TimedFloat6", "--out", "pose:My::TimedPose", "--idl", (kSource / "tests/install/custom_type/TimedPose.idl").string(),
       "--description", description, "--param", "gain:1/N:0.01:closing per newton", "--dir", root_.string()});
  ASSERT_EQ(made.exit_code, 0) << made.err;
  const fs::path project = root_ / "gripper_ctl", build = project / "build";
  CommandResult r = rtm_test::run_command({CMAKE_COMMAND, "-S", project.string(), "-B", build.string(),
                                           "-DCMAKE_PREFIX_PATH=" + prefix().string()},
                                          {"CMAKE_PREFIX_PATH=", "RTM_DIR="}, 300s);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  r = rtm_test::run_command({CMAKE_COMMAND, "--build", build.string(), "-j2"}, {}, 600s);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  r = rtm_test::run_command({"ctest", "--test-dir", build.string(), "--output-on-failure"}, {}, 120s);
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("100% tests passed"), std::string::npos) << r.out;
  r = rtm_test::run_command({(build / "bin" / "rtm-gripper_ctl").string(), "--help"}, {}, 30s);
  EXPECT_NE(r.out.find("rtm-gripper_ctl: " + description + ". InPorts: wrench RTM::TimedFloat6"), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("--gain"), std::string::npos) << "the parameter is an option: " << r.out;
  EXPECT_NE(r.out.find("closing per newton [1/N]"), std::string::npos) << r.out;
  // Its system file, from its folder, with the installed rtm and a runtime folder of the test's.
  const fs::path runtime = root_ / "run";
  fs::create_directories(runtime);
  auto rtm_here = [&](std::vector<std::string> args) {
    args.insert(args.begin(), {"/bin/sh", "-c", "cd \"$0\" && exec \"$@\"", project.string(), bin("rtm").string(),
                               "--naming", names_.address()});
    return rtm_test::run_command(args, {"XDG_RUNTIME_DIR=" + runtime.string(), "RTM_TLS="}, 60s);
  };
  r = rtm_here({"up", "gripper_ctl.yaml"});
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  r = rtm({"put", "gripper_ctl0.wrench", "1", "2", "3", "4", "5", "6"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  // Until the scaffold's logic has passed the input on (checked below, before `rtm down`).
  eventually([&] {
    const CommandResult twist = rtm({"get", "gripper_ctl0.twist"});
    return twist.exit_code == 0 && twist.out.find("1.000") != std::string::npos;
  });
  r = rtm({"get", "gripper_ctl0.twist"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("1.000"), std::string::npos) << "the scaffold's logic passes its input on: " << r.out;
  r = rtm({"--json", "get", "gripper_ctl0.pose"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(json::parse(r.out)["type"], "My::TimedPose") << r.out;
  r = rtm({"set", "gripper_ctl0", "gain", "0.02"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("gripper_ctl0.gain = 0.02"), std::string::npos) << "a live parameter of the scaffold: " << r.out;
  // The page's save keeps the value set: the saved file, brought up again, sets it.
  const std::string saved = save_from_the_page("gripper_saved");
  EXPECT_NE(saved.find("gain"), std::string::npos) << saved;
  std::ofstream(project / "saved.yaml") << saved;
  r = rtm_here({"down", "gripper_ctl"});
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  r = rtm_here({"up", "saved.yaml"});
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err << saved;
  r = rtm({"--json", "cat", "gripper_ctl0"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(json::parse(r.out)["parameters"]["gain"]["value"], "0.02") << "the saved value, not the default: " << r.out;
  r = rtm_here({"down", "gripper_saved"});
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
}

TEST_F(Installed, ATypesPackageInstallsItselfAndAComponentOfItsTypeFindsItBuildsAndCarriesIt) {
  const fs::path types = root_ / "types-prefix";
  const fs::path types_build = build_project(kSource / "tests/install/lab_types", "lab_types");
  CommandResult r = rtm_test::run_command({CMAKE_COMMAND, "--install", types_build.string(), "--prefix", types.string()});
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  for (const char* file : {"include/lab_types/lab_types.h", "include/lab_types/LabTypes.hh", "share/lab_types/idl/LabTypes.idl"})
    EXPECT_TRUE(fs::exists(types / file)) << file;
  EXPECT_NE(read_file(types / "include/lab_types/lab_types.h").find("RTM_DATA_TYPE(Lab, TimedTarget);"),
            std::string::npos);

  r = rtm_test::run_command({bin("rtm").string(), "new", "component", "follower", "--in", "target:Lab::TimedTarget",
                             "--out", "aim:Lab::TimedTarget", "--types", "lab_types", "--dir", root_.string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const fs::path build = build_in_place(root_ / "follower", root_ / "follower" / "build",
                                        prefix().string() + ";" + types.string());
  r = rtm_test::run_command({"ctest", "--test-dir", build.string(), "--output-on-failure"}, {}, 120s);
  EXPECT_NE(r.out.find("100% tests passed"), std::string::npos) << r.out << r.err;
  start(build / "bin" / "rtm-follower", "follower0", {"--on"});
  const CommandResult cat = rtm({"cat", "follower0"});
  EXPECT_NE(cat.out.find("Lab::TimedTarget"), std::string::npos) << cat.out;
  r = rtm({"put", "follower0.target", "0.5", "-1", "2", "7"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  json got;
  eventually([&] {
    r = rtm({"--json", "get", "follower0.aim"});
    if (r.exit_code != 0) return false;
    got = json::parse(r.out);
    return got["fields"]["id"] == 7;
  });
  EXPECT_EQ(got["values"], json::parse("[0.5, -1.0, 2.0, 7]")) << "the scaffold passes its input on: " << got.dump();
}

// find_package(RTM COMPONENTS core host) looks for what the core needs and not for the arm's
// libraries; a part that does not exist is not found, and the package then neither.
TEST_F(Installed, ThePackagesPartsBringOnlyTheirOwnDependencies) {
  const fs::path source = root_ / "parts";
  fs::create_directories(source);
  std::ofstream(source / "CMakeLists.txt") << R"(cmake_minimum_required(VERSION 3.25)
project(parts LANGUAGES CXX)
find_package(RTM 0.1 REQUIRED COMPONENTS core host)
if(NOT TARGET RTM::core OR NOT TARGET RTM::host)
  message(FATAL_ERROR "no RTM::core or RTM::host")
endif()
if(TARGET Eigen3::Eigen OR TARGET PkgConfig::OROCOS_KDL OR TARGET PkgConfig::URDFDOM)
  message(FATAL_ERROR "the arm's dependencies were looked for")
endif()
find_package(RTM 0.1 QUIET COMPONENTS core nonesuch)
if(RTM_FOUND)
  message(FATAL_ERROR "a part that does not exist was found")
endif()
message(STATUS "a part that does not exist: not found")
find_package(RTM 0.1 REQUIRED COMPONENTS pa10)
if(NOT TARGET PkgConfig::OROCOS_KDL)
  message(FATAL_ERROR "pa10 did not bring KDL")
endif()
)";
  const CommandResult r = rtm_test::run_command({CMAKE_COMMAND, "-S", source.string(), "-B", (root_ / "parts-build").string(),
                                                 "-DCMAKE_PREFIX_PATH=" + prefix().string()},
                                                {"CMAKE_PREFIX_PATH=", "RTM_DIR="}, 300s);
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("a part that does not exist: not found"), std::string::npos) << r.out;
}

// What a newcomer wires to first: the installed example system, by its installed path, with
// the installed programs on the PATH.
TEST_F(Installed, TheInstalledSourceSinkSystemComesUpWiredAndGoesDown) {
  const fs::path runtime = root_ / "run-examples";
  fs::create_directories(runtime);
  const std::vector<std::string> env{"XDG_RUNTIME_DIR=" + runtime.string(), "RTM_TLS=", "RTM_BIN_PATH=",
                                     "PATH=" + bin("").string() + ":/usr/bin:/bin"};
  const fs::path system = prefix() / "share/rtm/examples/source_sink/system.yaml";
  CommandResult r = rtm_test::run_command({bin("rtm").string(), "--naming", names_.address(), "up", system.string()},
                                          env, 60s);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_GT(wait_for_data("sink0", "in0"), 0u) << last_cat_;
  r = rtm_test::run_command({bin("rtm").string(), "--naming", names_.address(), "down", "source-sink"}, env, 60s);
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
}

// The same system with both in one host: the installed rtm-container loads the installed
// examples' modules, and the data crosses in-process.
TEST_F(Installed, TheInstalledSourceSinkSystemInOneContainerComesUpWiredInProcess) {
  const fs::path runtime = root_ / "run-examples-host";
  fs::create_directories(runtime);
  const std::vector<std::string> env{"XDG_RUNTIME_DIR=" + runtime.string(), "RTM_TLS=", "RTM_BIN_PATH=",
                                     "RTM_MODULE_PATH=", "PATH=" + bin("").string() + ":/usr/bin:/bin"};
  std::string yaml = read_file(prefix() / "share/rtm/examples/source_sink/system.yaml");
  for (const char* program : {"[rtm-example-source, --period, 2ms]", "[rtm-example-sink, --period, 2ms]"}) {
    const auto at = yaml.find(program);
    ASSERT_NE(at, std::string::npos) << yaml;
    yaml.insert(at + std::string(program).size(), "\n    host: example");
  }
  const fs::path system = runtime / "system.yaml";
  std::ofstream(system) << yaml;
  CommandResult r = rtm_test::run_command({bin("rtm").string(), "--naming", names_.address(), "up", system.string()},
                                          env, 60s);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("(2 components in one process)"), std::string::npos) << r.out;
  EXPECT_GT(wait_for_data("sink0", "in0"), 0u) << last_cat_;
  const json source = json::parse(rtm({"--json", "cat", "source0"}).out);
  for (const auto& p : source["ports"]) {
    if (p["name"] == "out0") {
      EXPECT_TRUE(p["subscriptions"].at(0)["in_process"].get<bool>()) << p.dump();
    }
  }
  r = rtm_test::run_command({bin("rtm").string(), "--naming", names_.address(), "down", "source-sink"}, env, 60s);
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
}

// rtm demo runs the demo installed beside it, on the programs beside it.
TEST_F(Installed, RtmDemoRunsTheInstalledDemoWithTheInstalledPrograms) {
  CommandResult r = rtm_test::run_command({bin("rtm").string(), "demo", "--help"}, {}, 30s);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("Usage: rtm demo [options]"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(prefix().string() + "/bin)"), std::string::npos) << "its programs: " << r.out;
  EXPECT_NE(r.out.find(prefix().string() + "/share/rtm/examples/force-servo/system.yaml"), std::string::npos) << r.out;
  const fs::path out = root_ / "demo-run";
  r = rtm_test::run_command({bin("rtm").string(), "demo", "--duration", "4", "--no-realtime", "--out", out.string()},
                            {"RTM_BIN_DIR=", "RTM_NAMING="}, 180s);
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(read_file(out / "summary.txt").find("Force servo:"), std::string::npos) << r.out << r.err;
  r = rtm_test::run_command({bin("rtm").string(), "demo", "--no-such-option"}, {}, 30s);
  EXPECT_EQ(r.exit_code, 2) << "the demo's own refusal: " << r.err;
  EXPECT_NE(r.err.find("unknown option '--no-such-option'"), std::string::npos) << r.err;
}

TEST_F(Installed, AProjectBuildsAgainstTheBuildTreeToo) {
  const fs::path source = root_ / "from-build-tree";
  fs::copy(kSource / "tests/install/custom_type", source, fs::copy_options::recursive);
  CommandResult r = rtm_test::run_command(
      {CMAKE_COMMAND, "-S", source.string(), "-B", (root_ / "from-build-tree-build").string(), "-DRTM_DIR=" + kBuild.string()},
      {"CMAKE_PREFIX_PATH="}, 300s);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  r = rtm_test::run_command({CMAKE_COMMAND, "--build", (root_ / "from-build-tree-build").string(), "-j2"}, {}, 600s);
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_TRUE(fs::exists(root_ / "from-build-tree-build" / "pose-relay"));
}

}  // namespace
