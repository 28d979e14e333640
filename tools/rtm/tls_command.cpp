// SPDX-License-Identifier: Apache-2.0
#include "tls_command.h"

#include "host/tls.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include <filesystem>

namespace rtm::cli {

namespace {

// user@host: who an identity made without --name is.
std::string default_identity_name() {
  char host[256] = {};
  if (::gethostname(host, sizeof host - 1) != 0) host[0] = '\0';
  const char* user = std::getenv("USER");
  return fmt::format("{}@{}", user && *user ? user : "rtm", host[0] ? host : "localhost");
}

}  // namespace

void TlsCommand::add_to(CLI::App& app) {
  CLI::App* tls = app.add_subcommand("tls", "certificates for systems across hosts (giop:ssl: endpoints, --tls)");
  tls->require_subcommand(1);
  init = tls->add_subcommand("init", "make a system's certificate authority and this host's TLS folder");
  init->add_option("folder", folder, "the folder to make (ca.pem, ca.key, identity.pem)")->required();
  init->add_option("--system", system, "the system's name, in the authority's certificate")->capture_default_str();
  issue = tls->add_subcommand("issue", "issue a TLS folder for another host with a system's authority");
  issue->add_option("authority", folder, "the folder `rtm tls init` made")->required();
  issue->add_option("folder", new_folder, "the folder to make (ca.pem, identity.pem), to copy to that host")
      ->required();
  for (CLI::App* sub : {init, issue}) {
    sub->add_option("--name", name, "the identity's name (default user@host)");
    sub->add_option("--days", days, "how long the certificates are valid")
        ->check(CLI::Range(1, 36500))
        ->capture_default_str();
  }
}

bool TlsCommand::parsed() const { return init->parsed() || issue->parsed(); }

void TlsCommand::run(bool json) const {
  const std::string identity = name.empty() ? default_identity_name() : name;
  const std::filesystem::path made = init->parsed() ? folder : new_folder;
  if (init->parsed()) {
    make_tls_authority(folder, system, identity, days);
  } else {
    issue_tls_identity(folder, new_folder, identity, days);
  }
  const TlsFolder check = check_tls_folder(made);  // what omniORB will read, read back
  if (json) {
    fmt::print("{}\n", nlohmann::json{{"folder", made.string()},
                                      {"authority", check.authority.string()},
                                      {"identity", check.identity.string()},
                                      {"name", check.subject}}
                           .dump());
    return;
  }
  fmt::print("made {}: ca.pem (the authority), identity.pem ({}, private){}\n", made.string(), check.subject,
             init->parsed() ? ", ca.key (issues identities: keep it on this host)" : "");
  fmt::print("use it: rtm --tls {0} ...  and components with --tls {0} (or RTM_TLS={0})\n", made.string());
}

}  // namespace rtm::cli
