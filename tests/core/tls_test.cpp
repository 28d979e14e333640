// SPDX-License-Identifier: Apache-2.0
// TLS folders (host/tls.h): what `rtm tls` makes, and every way a folder can be wrong getting a
// sentence that names the file, before omniORB would answer with a bare INITIALIZE.
#include "host/tls.h"

#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

namespace {

namespace fs = std::filesystem;

std::string read_text(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

mode_t mode_of(const fs::path& file) {
  struct stat st {};
  EXPECT_EQ(::stat(file.c_str(), &st), 0) << file;
  return st.st_mode & 0777;
}

// The message check_tls_folder throws for folder, or "" when it accepts it.
std::string refusal(const fs::path& folder) {
  try {
    rtm::check_tls_folder(folder);
    return "";
  } catch (const std::runtime_error& e) {
    return e.what();
  }
}

class TlsFolders : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / ("rtm-tls-" + std::to_string(::getpid()));
    fs::remove_all(root_);
    fs::create_directories(root_);
  }
  void TearDown() override { fs::remove_all(root_); }
  fs::path root_;
};

TEST_F(TlsFolders, InitMakesAnAuthorityAndAnIdentityItIssuedWithPrivateFilesPrivate) {
  const fs::path sys = root_ / "sys";
  rtm::make_tls_authority(sys, "cell7", "me@here", 30);
  EXPECT_EQ(mode_of(sys), 0700u);
  EXPECT_EQ(mode_of(sys / "ca.key"), 0600u);
  EXPECT_EQ(mode_of(sys / "identity.pem"), 0600u);
  EXPECT_EQ(mode_of(sys / "ca.pem"), 0644u);
  const rtm::TlsFolder folder = rtm::check_tls_folder(sys);
  EXPECT_EQ(folder.subject, "me@here");
  EXPECT_EQ(folder.authority, sys / "ca.pem");
  EXPECT_EQ(folder.identity, sys / "identity.pem");
  EXPECT_NE(read_text(sys / "identity.pem").find("PRIVATE KEY"), std::string::npos);
}

TEST_F(TlsFolders, IssueMakesAnotherHostsFolderWithoutTheAuthorityKey) {
  rtm::make_tls_authority(root_ / "sys", "cell7", "me@here", 30);
  rtm::issue_tls_identity(root_ / "sys", root_ / "hostb", "operator@hostb", 30);
  EXPECT_FALSE(fs::exists(root_ / "hostb" / "ca.key")) << "the authority's key must stay where it was made";
  EXPECT_EQ(read_text(root_ / "hostb" / "ca.pem"), read_text(root_ / "sys" / "ca.pem"));
  EXPECT_EQ(rtm::check_tls_folder(root_ / "hostb").subject, "operator@hostb");
  // Issuing needs the authority's key.
  EXPECT_THROW(rtm::issue_tls_identity(root_ / "hostb", root_ / "hostc", "x", 30), std::runtime_error);
  EXPECT_FALSE(fs::exists(root_ / "hostc"));
}

TEST_F(TlsFolders, NothingIsOverwrittenInitIntoAFolderWithFilesIsRefused) {
  rtm::make_tls_authority(root_ / "sys", "cell7", "me@here", 30);
  const std::string authority = read_text(root_ / "sys" / "ca.pem");
  const std::string key = read_text(root_ / "sys" / "ca.key");
  EXPECT_THROW(rtm::make_tls_authority(root_ / "sys", "cell7", "me@here", 30), std::runtime_error);
  EXPECT_THROW(rtm::issue_tls_identity(root_ / "sys", root_ / "sys", "x", 30), std::runtime_error);
  EXPECT_EQ(read_text(root_ / "sys" / "ca.pem"), authority);
  EXPECT_EQ(read_text(root_ / "sys" / "ca.key"), key);
}

TEST_F(TlsFolders, OutOfRangeDaysOrNamesAreRefusedBeforeAnythingIsMade) {
  EXPECT_THROW(rtm::make_tls_authority(root_ / "a", "cell7", "me", 0), std::invalid_argument);
  EXPECT_THROW(rtm::make_tls_authority(root_ / "b", "cell7", "", 30), std::invalid_argument);
  EXPECT_THROW(rtm::make_tls_authority(root_ / "c", "cell7", std::string(65, 'x'), 30), std::invalid_argument);
  EXPECT_FALSE(fs::exists(root_ / "a"));
  EXPECT_FALSE(fs::exists(root_ / "b"));
  EXPECT_FALSE(fs::exists(root_ / "c"));
}

TEST_F(TlsFolders, AMissingFolderOrFileIsNamed) {
  EXPECT_NE(refusal(root_ / "nosuch").find("no such TLS folder"), std::string::npos);
  rtm::make_tls_authority(root_ / "sys", "cell7", "me@here", 30);
  fs::remove(root_ / "sys" / "ca.pem");
  const std::string why = refusal(root_ / "sys");
  EXPECT_NE(why.find("ca.pem: cannot read it"), std::string::npos) << why;
}

TEST_F(TlsFolders, AnIdentityOthersMayReadIsRefused) {
  rtm::make_tls_authority(root_ / "sys", "cell7", "me@here", 30);
  fs::permissions(root_ / "sys" / "identity.pem", fs::perms::group_read | fs::perms::others_read,
                  fs::perm_options::add);
  const std::string why = refusal(root_ / "sys");
  EXPECT_NE(why.find("identity.pem: others may read this private key"), std::string::npos) << why;
}

TEST_F(TlsFolders, AnIdentityOfAnotherAuthorityIsRefused) {
  rtm::make_tls_authority(root_ / "sys", "cell7", "me@here", 30);
  rtm::make_tls_authority(root_ / "foreign", "cell8", "them@there", 30);
  fs::copy_file(root_ / "foreign" / "ca.pem", root_ / "sys" / "ca.pem", fs::copy_options::overwrite_existing);
  const std::string why = refusal(root_ / "sys");
  EXPECT_NE(why.find("does not verify against"), std::string::npos) << why;
}

TEST_F(TlsFolders, ACertificateWithAnotherIdentitysKeyIsRefused) {
  rtm::make_tls_authority(root_ / "sys", "cell7", "me@here", 30);
  rtm::issue_tls_identity(root_ / "sys", root_ / "b", "b", 30);
  // identity.pem: sys's certificate, then b's key.
  const std::string mine = read_text(root_ / "sys" / "identity.pem");
  const std::string theirs = read_text(root_ / "b" / "identity.pem");
  const std::string spliced = mine.substr(0, mine.find("-----BEGIN PRIVATE KEY")) +
                              theirs.substr(theirs.find("-----BEGIN PRIVATE KEY"));
  std::ofstream(root_ / "sys" / "identity.pem", std::ios::trunc) << spliced;
  const std::string why = refusal(root_ / "sys");
  EXPECT_NE(why.find("its private key does not belong to its certificate"), std::string::npos) << why;
}

TEST_F(TlsFolders, MalformedPemIsRefusedNamingTheFile) {
  rtm::make_tls_authority(root_ / "sys", "cell7", "me@here", 30);
  std::ofstream(root_ / "sys" / "ca.pem", std::ios::trunc) << "-----BEGIN CERTIFICATE-----\nnot base64 @@@\n";
  std::string why = refusal(root_ / "sys");
  EXPECT_NE(why.find("ca.pem: holds no PEM certificate"), std::string::npos) << why;
  // A certificate without its key.
  fs::remove_all(root_ / "sys");
  rtm::make_tls_authority(root_ / "sys", "cell7", "me@here", 30);
  const std::string identity = read_text(root_ / "sys" / "identity.pem");
  std::ofstream(root_ / "sys" / "identity.pem", std::ios::trunc)
      << identity.substr(0, identity.find("-----BEGIN PRIVATE KEY"));
  why = refusal(root_ / "sys");
  EXPECT_NE(why.find("identity.pem: holds no unencrypted PEM private key"), std::string::npos) << why;
}

}  // namespace
