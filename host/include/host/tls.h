// SPDX-License-Identifier: Apache-2.0
// TLS with client certificates: changing a system from another host.
//
// A system's certificate authority (a CA of its own, made by `rtm tls init`) is what the
// members of a system trust. A *TLS folder* holds what one host needs to take part:
//
//   ca.pem        the authority's certificate (public)
//   identity.pem  this host's certificate, issued by that authority, and its private key
//                 (mode 0600, owned by the user)
//   ca.key        the authority's private key: only in the folder `rtm tls init` made; it
//                 issues identities (`rtm tls issue`) and belongs on no other host.
//
// A process configured with a folder (configure_tls, before rtm::Orb) can listen on and call
// giop:ssl: endpoints. omniORB's SSL transport then requires a certificate from every peer and
// checks it against ca.pem in the handshake: a peer without one, or with one from another
// authority, gets no connection at all. A request that arrives over such a verified connection
// may change the component (host/access.h) without the owner's access key: the certificate is
// the credential across hosts. Host names are not checked: the authority is the trust.
#pragma once

#include <omniORB4/CORBA.h>

#include <filesystem>
#include <string>
#include <string_view>

namespace rtm {

// The environment variable rtm and every component read for a TLS folder when --tls is not given.
inline constexpr const char* kTlsFolderVariable = "RTM_TLS";

struct TlsFolder {
  std::filesystem::path authority;  // ca.pem
  std::filesystem::path identity;   // identity.pem
  std::string subject;              // the identity's common name
};

// Checks folder as omniORB will use it, so that a mistake gets a sentence instead of
// omniORB's INITIALIZE: both files present and PEM, the identity holding a certificate and
// the private key that belongs to it, not readable by others, issued by ca.pem and not
// expired. Throws std::runtime_error naming the file and what is wrong.
TlsFolder check_tls_folder(const std::filesystem::path& folder);

// Makes omniORB's SSL transport use folder's files; call before rtm::Orb is made (omniORB
// reads them in ORB_init). The paths are kept for the life of the process.
void configure_tls(const TlsFolder& folder);
// Whether configure_tls was called in this process.
bool tls_configured();
// Whether object's reference offers only giop:ssl: addresses (no TCP, no giop:unix:): a
// process without certificates cannot reach it, whether or not it is alive.
bool reachable_only_over_tls(CORBA::Object_ptr object);

// Names across hosts. omniNames has no access control: whoever reaches it can bind a name to
// an object of their own. A process with certificates therefore checks, before it trusts a
// name, that the component behind it is a member of its system on the name's host:
// system_membership_problem(object, host) makes one call to the object and looks at the
// connection it went over: over giop:ssl: the certificate omniORB verified against ca.pem must
// name that host ("<who>@<host>", as `rtm tls` names identities, or "<host>"); over giop:unix:
// the name's host must be this one and the process this user's (or root's); plain TCP shows
// nothing and is refused. Returns "" when the object is a member (or lives in this process),
// else the sentence why not. Throws the call's CORBA exception (TRANSIENT: gone, or no TLS
// connection: tls_handshake_problem says which).
std::string system_membership_problem(CORBA::Object_ptr object, std::string_view host);
// Whether identity (a certificate's common name) is one of host's: "<who>@<host>" or "<host>".
bool identity_names_host(std::string_view identity, std::string_view host);

// Why no TLS connection to object can be made, found by a handshake of this process's own
// with its certificates against each of the object's giop:ssl: addresses: "its certificate was
// not issued by this system's authority (...)" or "it refused this process's certificate
// (...)". "" when a handshake succeeds or no address answers (the process is gone). For a call
// that failed with TRANSIENT while certificates are configured; costs up to about a second.
std::string tls_handshake_problem(CORBA::Object_ptr object);

// rtm tls init: makes folder (0700; must not exist or be empty) with a new authority for a
// system (its certificate's common name "<system> CA"), its key, and a first identity named
// identity_name. Valid for days days. Throws std::runtime_error when anything cannot be made;
// never overwrites a file.
void make_tls_authority(const std::filesystem::path& folder, const std::string& system,
                        const std::string& identity_name, int days);

// rtm tls issue: makes folder (as above) with a copy of authority_folder's ca.pem and a new
// identity named name, issued with authority_folder's ca.key: a folder to copy to another host.
void issue_tls_identity(const std::filesystem::path& authority_folder, const std::filesystem::path& folder,
                        const std::string& name, int days);

}  // namespace rtm
