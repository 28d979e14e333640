// SPDX-License-Identifier: Apache-2.0
// Components across hosts: giop:ssl: endpoints with client certificates (host/tls.h), driven as
// a user drives them: `rtm tls` makes the folders, real component processes serve only
// giop:ssl: on loopback, and the real `rtm` reaches them with one folder or another.
#include "rtm_test/run_command.h"

#include "rtm_test/child_process.h"
#include "rtm_test/omni_names.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <unistd.h>

#include <filesystem>
#include <memory>
#include <thread>

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using rtm_test::ChildProcess;
using rtm_test::CommandResult;
using rtm_test::OmniNames;
using namespace std::chrono_literals;

class RtmTls : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("rtm-tls-cli-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    // The system's authority and this host's folder; another host's folder it issued; a
    // folder of another system's authority.
    ASSERT_EQ(run({"tls", "init", (dir_ / "sys").string(), "--system", "cell7"}).exit_code, 0);
    ASSERT_EQ(run({"tls", "issue", (dir_ / "sys").string(), (dir_ / "hostb").string(), "--name", "op@b"}).exit_code,
              0);
    ASSERT_EQ(run({"tls", "init", (dir_ / "foreign").string(), "--system", "other"}).exit_code, 0);
  }
  void TearDown() override {
    talkers_.clear();
    fs::remove_all(dir_);
  }

  // rtm reaching the TLS-only components over giop:ssl:, where only a certificate can let its
  // changes through. folder: --tls, or none.
  CommandResult run(std::vector<std::string> args, const std::string& folder = "") {
    std::vector<std::string> argv{RTM_CLI_PATH, "--naming", names_.address()};
    if (!folder.empty()) argv.insert(argv.end(), {"--tls", (dir_ / folder).string()});
    argv.insert(argv.end(), args.begin(), args.end());
    return rtm_test::run_command(argv, {"RTM_TLS="});
  }
  json run_json(std::vector<std::string> args, const std::string& folder) {
    args.insert(args.begin(), "--json");
    const CommandResult r = run(args, folder);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return r.exit_code == 0 ? json::parse(r.out) : json();
  }
  // A component serving only giop:ssl: on loopback with the system's folder.
  ChildProcess& tls_talker(const std::string& name, std::vector<std::string> extra = {}) {
    std::vector<std::string> argv{TALKER_PATH, "--name",   name, "--naming", names_.address(), "--tls",
                                  (dir_ / "sys").string(), "--endpoint", "giop:ssl:127.0.0.1:"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    return rtm_test::start_bound(talkers_, argv);
  }
  std::string state_of(const std::string& name) {
    const json list = run_json({"ls"}, "sys");
    for (const auto& c : list)
      if (c["name"] == name) return c.value("state", "?");
    return "absent";
  }

  OmniNames names_;
  fs::path dir_;
  std::vector<std::unique_ptr<ChildProcess>> talkers_;
};

TEST_F(RtmTls, ACertificateOfTheSystemsAuthorityMayChangeATlsOnlyComponent) {
  tls_talker("alpha", {"--on"});
  ASSERT_EQ(state_of("alpha"), "on");
  const CommandResult off = run({"off", "alpha"}, "hostb");
  EXPECT_EQ(off.exit_code, 0) << off.err;
  EXPECT_EQ(state_of("alpha"), "off");
  const CommandResult on = run({"on", "alpha"}, "hostb");
  EXPECT_EQ(on.exit_code, 0) << on.err;
  EXPECT_EQ(state_of("alpha"), "on");
}

TEST_F(RtmTls, ACertificateOfAnotherAuthorityGetsNoConnectionAndChangesNothing) {
  tls_talker("alpha", {"--on"});
  const CommandResult off = run({"off", "alpha"}, "foreign");
  EXPECT_EQ(off.exit_code, 1) << off.out;
  EXPECT_NE(off.err.find("alpha"), std::string::npos) << off.err;
  EXPECT_NE(off.err.find("no TLS connection: its certificate was not issued by this system's authority"),
            std::string::npos)
      << "a bare TRANSIENT where a sentence is owed: " << off.err;
  const CommandResult put = run({"put", "alpha.in0", "1", "2", "3", "4", "5", "6"}, "foreign");
  EXPECT_EQ(put.exit_code, 1) << put.out;
  EXPECT_EQ(state_of("alpha"), "on");
  const json alpha = run_json({"cat", "alpha"}, "sys");
  EXPECT_EQ(alpha["ports"][0]["counters"]["accepted"], 0) << "a put through a foreign certificate arrived";
}

// omniNames lets anyone bind a name: a component whose certificate names another host, bound
// under this host's name, is no member of the system here, and nothing is asked of it.
TEST_F(RtmTls, ANameThatLeadsToACertificateOfAnotherHostIsRefusedBeforeAnyChange) {
  tls_talker("alpha", {"--on"});
  std::vector<std::string> argv{TALKER_PATH, "--name", "impostor", "--naming", names_.address(), "--tls",
                                (dir_ / "hostb").string(), "--endpoint", "giop:ssl:127.0.0.1:", "--on"};
  rtm_test::start_bound(talkers_, argv);
  const CommandResult off = run({"off", "impostor"}, "sys");
  EXPECT_EQ(off.exit_code, 1) << off.out;
  EXPECT_NE(off.err.find("is not this system's: its certificate names op@b"), std::string::npos) << off.err;
  const CommandResult ls = run({"ls"}, "sys");
  EXPECT_EQ(ls.exit_code, 0) << ls.err;
  EXPECT_NE(ls.out.find("its certificate names op@b"), std::string::npos) << ls.out;
  EXPECT_EQ(state_of("alpha"), "on") << "the member beside it is listed as before";
  const CommandResult clean = run({"ls", "--clean"}, "sys");
  EXPECT_NE(clean.out.find("no dead bindings"), std::string::npos) << "a non-member was cleaned: " << clean.out;
}

TEST_F(RtmTls, WithoutCertificatesATlsOnlyComponentIsOutOfReachNeitherDeadNorCleaned) {
  tls_talker("alpha", {"--on"});
  const CommandResult ls = run({"ls"});
  EXPECT_EQ(ls.exit_code, 0) << ls.err;
  EXPECT_NE(ls.out.find("out of reach"), std::string::npos) << ls.out;
  EXPECT_EQ(ls.out.find("dead"), std::string::npos) << ls.out;
  const CommandResult clean = run({"ls", "--clean"});
  EXPECT_EQ(clean.exit_code, 0) << clean.err;
  EXPECT_NE(clean.out.find("no dead bindings"), std::string::npos) << clean.out;
  const CommandResult off = run({"off", "alpha"});
  EXPECT_EQ(off.exit_code, 1);
  EXPECT_NE(off.err.find("giop:ssl: needs --tls"), std::string::npos) << off.err;
  EXPECT_EQ(state_of("alpha"), "on") << "the binding or the component was touched";
}

TEST_F(RtmTls, DataFlowsBetweenTwoTlsOnlyComponentsWiredFromAnotherHostsFolder) {
  tls_talker("src", {"--on"});
  tls_talker("dst");
  const CommandResult connect = run({"connect", "src.force", "dst.in0"}, "hostb");
  ASSERT_EQ(connect.exit_code, 0) << connect.err;
  std::uint64_t accepted = 0;
  for (int i = 0; i < 50 && accepted == 0; ++i) {
    std::this_thread::sleep_for(20ms);
    const json dst = run_json({"cat", "dst"}, "hostb");
    accepted = dst["ports"][0]["counters"]["accepted"].get<std::uint64_t>();
  }
  EXPECT_GT(accepted, 0u) << "src's delivery over giop:ssl: reached dst";
}

TEST_F(RtmTls, BadTlsSettingsStopAComponentWithAClearErrorBeforeItBinds) {
  // A giop:ssl: endpoint without certificates: a usage error.
  CommandResult r = rtm_test::run_command(
      {TALKER_PATH, "--name", "x", "--naming", names_.address(), "--endpoint", "giop:ssl:127.0.0.1:"}, {"RTM_TLS="});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("needs certificates: --tls FOLDER"), std::string::npos) << r.err;
  // An identity others may read.
  fs::permissions(dir_ / "hostb" / "identity.pem", fs::perms::others_read, fs::perm_options::add);
  r = rtm_test::run_command({TALKER_PATH, "--name", "x", "--naming", names_.address(), "--tls",
                             (dir_ / "hostb").string(), "--endpoint", "giop:ssl:127.0.0.1:"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("others may read this private key"), std::string::npos) << r.err;
  // rtm refuses the same folder the same way.
  r = run({"ls"}, "hostb");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("--tls: "), std::string::npos) << r.err;
  EXPECT_EQ(run_json({"ls"}, "sys").size(), 0u) << "a component bound although its settings were refused";
}

TEST_F(RtmTls, TlsInitRefusesAFolderThatHasFilesAndOverwritesNothing) {
  const CommandResult again = run({"tls", "init", (dir_ / "sys").string()});
  EXPECT_EQ(again.exit_code, 1);
  EXPECT_NE(again.err.find("not empty"), std::string::npos) << again.err;
  EXPECT_EQ(run_json({"ls"}, "sys").size(), 0u) << "the folder no longer works";
}

}  // namespace
