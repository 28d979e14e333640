// SPDX-License-Identifier: Apache-2.0
#include "host/tls.h"

#include "host/access.h"
#include "rtm/naming.h"
#include "rtm/orb.h"

#include <netdb.h>
#include <poll.h>
#include <sys/socket.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <openssl/bn.h>
#include <openssl/err.h>
#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/ssl.h>
#include <openssl/x509.h>
#include <openssl/x509v3.h>

#include <omniORB4/CORBA.h>
#include <omniORB4/IIOP.h>
#include <omniORB4/omniIOR.h>
#include <omniORB4/omniObjRef.h>
#include <omniORB4/sslContext.h>

#include <fmt/format.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>
#include <optional>
#include <stdexcept>
#include <vector>

namespace rtm {

namespace {

namespace fs = std::filesystem;

template <auto Free>
struct Deleter {
  template <typename T>
  void operator()(T* p) const {
    Free(p);
  }
};
using X509Ptr = std::unique_ptr<X509, Deleter<X509_free>>;
using KeyPtr = std::unique_ptr<EVP_PKEY, Deleter<EVP_PKEY_free>>;
using StorePtr = std::unique_ptr<X509_STORE, Deleter<X509_STORE_free>>;
using StoreContextPtr = std::unique_ptr<X509_STORE_CTX, Deleter<X509_STORE_CTX_free>>;
void close_file_quietly(FILE* f) { std::fclose(f); }
using FilePtr = std::unique_ptr<FILE, Deleter<close_file_quietly>>;

constexpr const char* kAuthorityFile = "ca.pem";
constexpr const char* kAuthorityKeyFile = "ca.key";
constexpr const char* kIdentityFile = "identity.pem";

// What OpenSSL last reported, emptying its queue.
std::string openssl_error() {
  std::string text;
  while (const unsigned long code = ERR_get_error()) {
    char buffer[256];
    ERR_error_string_n(code, buffer, sizeof buffer);
    if (!text.empty()) text += "; ";
    text += buffer;
  }
  return text.empty() ? "no detail" : text;
}

[[noreturn]] void fail(const fs::path& file, const std::string& what) {
  throw std::runtime_error(file.string() + ": " + what);
}

FilePtr open_for_reading(const fs::path& file) {
  FILE* f = std::fopen(file.c_str(), "re");
  if (!f) fail(file, std::string("cannot read it: ") + std::strerror(errno));
  return FilePtr(f);
}

X509Ptr read_certificate(const fs::path& file) {
  FilePtr f = open_for_reading(file);
  X509Ptr cert(PEM_read_X509(f.get(), nullptr, nullptr, nullptr));
  if (!cert) fail(file, "holds no PEM certificate (" + openssl_error() + ")");
  return cert;
}

KeyPtr read_private_key(const fs::path& file) {
  FilePtr f = open_for_reading(file);
  // An empty password: a key protected by one is refused rather than prompted for.
  KeyPtr key(PEM_read_PrivateKey(f.get(), nullptr, nullptr, const_cast<char*>("")));
  if (!key) fail(file, "holds no unencrypted PEM private key (" + openssl_error() + ")");
  return key;
}

std::string common_name(X509* cert) {
  char buffer[256] = {};
  if (X509_NAME_get_text_by_NID(X509_get_subject_name(cert), NID_commonName, buffer, sizeof buffer) <= 0) return {};
  return buffer;
}

// The identity holds a private key: only its user may read it, as ssh asks of its keys.
void check_private(const fs::path& file) {
  struct stat st {};
  if (::stat(file.c_str(), &st) != 0) fail(file, std::string("cannot read it: ") + std::strerror(errno));
  if (st.st_uid != ::geteuid()) fail(file, "belongs to another user; a private key must be its user's own");
  if ((st.st_mode & 077) != 0) fail(file, "others may read this private key: chmod 600 it");
}

void verify_issued_by(X509* cert, X509* authority, const fs::path& file, const fs::path& authority_file) {
  StorePtr store(X509_STORE_new());
  StoreContextPtr context(X509_STORE_CTX_new());
  if (!store || !context || X509_STORE_add_cert(store.get(), authority) != 1 ||
      X509_STORE_CTX_init(context.get(), store.get(), cert, nullptr) != 1)
    fail(file, "cannot check its certificate (" + openssl_error() + ")");
  if (X509_verify_cert(context.get()) != 1) {
    const int error = X509_STORE_CTX_get_error(context.get());
    fail(file, std::string("its certificate does not verify against ") + authority_file.string() + ": " +
                   X509_verify_cert_error_string(error));
  }
}

// ---- making certificates ----

// A new file only its user may read (0600) or anyone (0644); never an existing one.
FilePtr create_file(const fs::path& file, mode_t mode) {
  const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, mode);
  if (fd < 0) fail(file, std::string("cannot make it: ") + std::strerror(errno));
  ::fchmod(fd, mode);  // whatever the umask
  FILE* f = ::fdopen(fd, "w");
  if (!f) {
    ::close(fd);
    fail(file, "cannot write it");
  }
  return FilePtr(f);
}

void write_certificate(FILE* f, X509* cert, const fs::path& file) {
  if (PEM_write_X509(f, cert) != 1) fail(file, "cannot write the certificate (" + openssl_error() + ")");
}

void write_private_key(FILE* f, EVP_PKEY* key, const fs::path& file) {
  if (PEM_write_PrivateKey(f, key, nullptr, nullptr, 0, nullptr, nullptr) != 1)
    fail(file, "cannot write the private key (" + openssl_error() + ")");
}

void close_file(FilePtr f, const fs::path& file) {
  if (std::fflush(f.get()) != 0 || ::fsync(::fileno(f.get())) != 0)
    fail(file, std::string("cannot write it: ") + std::strerror(errno));
  if (std::fclose(f.release()) != 0) fail(file, std::string("cannot write it: ") + std::strerror(errno));
}

// A folder of our own to fill: made 0700, or an existing empty one.
void make_folder(const fs::path& folder) {
  if (::mkdir(folder.c_str(), 0700) == 0) return;
  if (errno != EEXIST) fail(folder, std::string("cannot make the folder: ") + std::strerror(errno));
  std::error_code error;
  if (!fs::is_directory(folder, error)) fail(folder, "exists and is no folder");
  if (!fs::is_empty(folder, error)) fail(folder, "exists and is not empty; certificates are never overwritten");
}

KeyPtr new_key(const std::string& what) {
  KeyPtr key(EVP_EC_gen("P-256"));
  if (!key) throw std::runtime_error("cannot make a key for " + what + " (" + openssl_error() + ")");
  return key;
}

void add_extension(X509* cert, X509* issuer, int nid, const char* value) {
  X509V3_CTX context;
  X509V3_set_ctx_nodb(&context);
  X509V3_set_ctx(&context, issuer, cert, nullptr, nullptr, 0);
  X509_EXTENSION* extension = X509V3_EXT_conf_nid(nullptr, &context, nid, value);
  if (!extension || X509_add_ext(cert, extension, -1) != 1) {
    X509_EXTENSION_free(extension);
    throw std::runtime_error(std::string("cannot add certificate extension ") + value + " (" + openssl_error() + ")");
  }
  X509_EXTENSION_free(extension);
}

// A certificate for key named name, issued by issuer (null: self-signed) with issuer_key.
X509Ptr new_certificate(EVP_PKEY* key, const std::string& name, bool authority, X509* issuer, EVP_PKEY* issuer_key,
                        int days) {
  X509Ptr cert(X509_new());
  std::unique_ptr<BIGNUM, Deleter<BN_free>> serial(BN_new());
  bool ok = cert && serial && X509_set_version(cert.get(), 2) == 1 && BN_rand(serial.get(), 127, 0, 0) == 1 &&
            BN_to_ASN1_INTEGER(serial.get(), X509_get_serialNumber(cert.get())) != nullptr &&
            X509_gmtime_adj(X509_getm_notBefore(cert.get()), -3600) != nullptr &&
            X509_gmtime_adj(X509_getm_notAfter(cert.get()), static_cast<long>(days) * 86400) != nullptr &&
            X509_set_pubkey(cert.get(), key) == 1;
  X509_NAME* subject = X509_get_subject_name(cert.get());
  ok = ok &&
       X509_NAME_add_entry_by_txt(subject, "O", MBSTRING_UTF8,
                                  reinterpret_cast<const unsigned char*>("RTM system"), -1, -1, 0) == 1 &&
       X509_NAME_add_entry_by_txt(subject, "CN", MBSTRING_UTF8, reinterpret_cast<const unsigned char*>(name.c_str()),
                                  -1, -1, 0) == 1 &&
       X509_set_issuer_name(cert.get(), issuer ? X509_get_subject_name(issuer) : subject) == 1;
  if (!ok) throw std::runtime_error("cannot make the certificate of " + name + " (" + openssl_error() + ")");
  X509* signer = issuer ? issuer : cert.get();
  add_extension(cert.get(), signer, NID_subject_key_identifier, "hash");
  if (authority) {
    add_extension(cert.get(), signer, NID_basic_constraints, "critical,CA:TRUE,pathlen:0");
    add_extension(cert.get(), signer, NID_key_usage, "critical,keyCertSign,cRLSign");
  } else {
    add_extension(cert.get(), signer, NID_authority_key_identifier, "keyid:always");
    add_extension(cert.get(), signer, NID_basic_constraints, "critical,CA:FALSE");
    add_extension(cert.get(), signer, NID_key_usage, "critical,digitalSignature,keyAgreement");
    add_extension(cert.get(), signer, NID_ext_key_usage, "serverAuth,clientAuth");
  }
  if (X509_sign(cert.get(), issuer_key ? issuer_key : key, EVP_sha256()) == 0)
    throw std::runtime_error("cannot sign the certificate of " + name + " (" + openssl_error() + ")");
  return cert;
}

void check_request(const std::string& name, int days) {
  if (name.empty() || name.size() > 64) throw std::invalid_argument("a certificate's name has 1 to 64 characters");
  if (days < 1 || days > 36500) throw std::invalid_argument("a certificate is valid for 1 to 36500 days");
}

// identity.pem: the certificate, then its key (the layout omniORB's key_file reads).
void write_identity(const fs::path& folder, const std::string& name, X509* authority, EVP_PKEY* authority_key,
                    int days) {
  KeyPtr key = new_key(name);
  X509Ptr cert = new_certificate(key.get(), name, false, authority, authority_key, days);
  const fs::path file = folder / kIdentityFile;
  FilePtr f = create_file(file, 0600);
  write_certificate(f.get(), cert.get(), file);
  write_private_key(f.get(), key.get(), file);
  close_file(std::move(f), file);
}

void write_authority_certificate(const fs::path& folder, X509* authority) {
  const fs::path file = folder / kAuthorityFile;
  FilePtr f = create_file(file, 0644);
  write_certificate(f.get(), authority, file);
  close_file(std::move(f), file);
}

// What omniORB reads in ORB_init; kept for the life of the process.
struct TlsSettings {
  std::string authority;
  std::string identity;
  std::atomic<bool> configured{false};
};
TlsSettings g_tls;

// The IIOP profiles of an object's reference (each an address and its tagged components);
// nullopt when one cannot be read or the object is nil.
std::optional<std::vector<IIOP::ProfileBody>> iiop_profiles(CORBA::Object_ptr object) {
  if (CORBA::is_nil(object) || !object->_PR_getobj()) return std::nullopt;
  omniIOR_var ior = object->_PR_getobj()->_getIOR();
  const IOP::TaggedProfileList& profiles = ior->iopProfiles();
  std::vector<IIOP::ProfileBody> bodies;
  for (CORBA::ULong i = 0; i < profiles.length(); ++i) {
    if (profiles[i].tag != IOP::TAG_INTERNET_IOP) continue;
    try {
      IIOP::unmarshalProfile(profiles[i], bodies.emplace_back());
    } catch (const CORBA::SystemException&) {
      return std::nullopt;
    }
  }
  return bodies;
}

}  // namespace

TlsFolder check_tls_folder(const fs::path& folder) {
  std::error_code error;
  if (!fs::is_directory(folder, error)) fail(folder, "no such TLS folder (`rtm tls init` makes one)");
  TlsFolder result{folder / kAuthorityFile, folder / kIdentityFile, {}};
  X509Ptr authority = read_certificate(result.authority);
  check_private(result.identity);
  X509Ptr cert = read_certificate(result.identity);
  KeyPtr key = read_private_key(result.identity);
  if (X509_check_private_key(cert.get(), key.get()) != 1)
    fail(result.identity, "its private key does not belong to its certificate");
  verify_issued_by(cert.get(), authority.get(), result.identity, result.authority);
  result.subject = common_name(cert.get());
  if (result.subject.empty()) fail(result.identity, "its certificate has no common name");
  return result;
}

void configure_tls(const TlsFolder& folder) {
  g_tls.authority = folder.authority.string();
  g_tls.identity = folder.identity.string();
  sslContext::certificate_authority_file = g_tls.authority.c_str();
  sslContext::key_file = g_tls.identity.c_str();
  // omniORB loads the private key only when a password is set; ours are not encrypted.
  sslContext::key_file_password = "";
  sslContext::verify_mode = SSL_VERIFY_PEER | SSL_VERIFY_FAIL_IF_NO_PEER_CERT;
  g_tls.configured.store(true);
  process_hooks().certificates = true;
  process_hooks().membership_problem = [](CORBA::Object_ptr object, const std::string& host) -> std::string {
    try {
      return system_membership_problem(object, host);
    } catch (const CORBA::TRANSIENT&) {
      const std::string problem = tls_handshake_problem(object);
      return problem.empty() ? "" : "no TLS connection: " + problem;
    } catch (const CORBA::SystemException&) {
      return "";  // gone or hung: the caller's own call finds that out and says so
    }
  };
}

bool tls_configured() { return g_tls.configured.load(); }

bool reachable_only_over_tls(CORBA::Object_ptr object) {
  const std::optional<std::vector<IIOP::ProfileBody>> bodies = iiop_profiles(object);
  if (!bodies) return false;
  bool ssl = false;
  for (const IIOP::ProfileBody& body : *bodies) {
    if (body.address.port != 0) return false;  // a plain TCP address
    for (CORBA::ULong c = 0; c < body.components.length(); ++c) {
      const IOP::ComponentId tag = body.components[c].tag;
      if (tag == IOP::TAG_SSL_SEC_TRANS) ssl = true;
      if (tag == IOP::TAG_OMNIORB_UNIX_TRANS || tag == IOP::TAG_ALTERNATE_IIOP_ADDRESS) return false;
    }
  }
  return ssl;
}

bool identity_names_host(std::string_view identity, std::string_view host) {
  if (host.empty()) return false;
  if (identity == host) return true;
  const auto at = identity.rfind('@');
  return at != std::string_view::npos && identity.substr(at + 1) == host;
}

std::string system_membership_problem(CORBA::Object_ptr object, std::string_view host) {
  const std::optional<Peer> peer = peer_of(object);
  if (!peer) return "";  // a servant of this process
  switch (peer->transport) {
    case Transport::tls:
      if (peer->identity.empty()) return "its TLS connection presented no certificate this process verified";
      if (identity_names_host(peer->identity, host)) return "";
      return fmt::format("its certificate names {}, not a member of this system on host {}", peer->identity, host);
    case Transport::unix_socket:
    case Transport::tcp: {
      if (!peer->uid) break;  // TCP from another host
      const std::string here = local_host_name();
      if (host != here) return fmt::format("it is a process on this host ({}), not on {}", here, host);
      if (!is_owner_uid(*peer->uid)) return fmt::format("it is another user's process (uid {})", *peer->uid);
      return "";
    }
    case Transport::other: break;
  }
  return "it answers over plain TCP from another host (" + peer->address + "), where it shows no certificate of this system";
}

namespace {

struct SslAddress {
  std::string host;
  std::uint16_t port = 0;
};

// The giop:ssl: addresses an object's reference offers: each IIOP profile's host with the
// port of its TAG_SSL_SEC_TRANS component (a CDR encapsulation of three unsigned shorts:
// target_supports, target_requires, port).
std::vector<SslAddress> ssl_addresses(CORBA::Object_ptr object) {
  std::vector<SslAddress> out;
  for (const IIOP::ProfileBody& body : iiop_profiles(object).value_or(std::vector<IIOP::ProfileBody>{})) {
    for (CORBA::ULong c = 0; c < body.components.length(); ++c) {
      const IOP::TaggedComponent& component = body.components[c];
      if (component.tag != IOP::TAG_SSL_SEC_TRANS || component.component_data.length() < 8) continue;
      const CORBA::Octet* data = component.component_data.get_buffer();
      const bool little = data[0] != 0;
      const auto port = static_cast<std::uint16_t>(little ? data[6] | (data[7] << 8) : (data[6] << 8) | data[7]);
      out.push_back({body.address.host.in(), port});
    }
  }
  return out;
}

using SslContextPtr = std::unique_ptr<SSL_CTX, Deleter<SSL_CTX_free>>;
using SslPtr = std::unique_ptr<SSL, Deleter<SSL_free>>;

struct Descriptor {
  int fd = -1;
  ~Descriptor() {
    if (fd >= 0) ::close(fd);
  }
};

// A TCP connection to host:port within timeout_ms, or -1.
int connect_within(const SslAddress& address, int timeout_ms) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* found = nullptr;
  if (::getaddrinfo(address.host.c_str(), std::to_string(address.port).c_str(), &hints, &found) != 0) return -1;
  int connected = -1;
  for (addrinfo* a = found; a && connected < 0; a = a->ai_next) {
    const int fd = ::socket(a->ai_family, a->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, a->ai_protocol);
    if (fd < 0) continue;
    int error = 0;
    socklen_t size = sizeof error;
    pollfd wait{fd, POLLOUT, 0};
    const bool ok = (::connect(fd, a->ai_addr, a->ai_addrlen) == 0 ||
                     (errno == EINPROGRESS && ::poll(&wait, 1, timeout_ms) == 1 &&
                      ::getsockopt(fd, SOL_SOCKET, SO_ERROR, &error, &size) == 0 && error == 0));
    if (ok) {
      ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
      const timeval bound{0, timeout_ms * 1000};
      ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &bound, sizeof bound);
      ::setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &bound, sizeof bound);
      connected = fd;
    } else {
      ::close(fd);
    }
  }
  ::freeaddrinfo(found);
  return connected;
}

// One handshake with this process's certificates, as omniORB's would be: "" when it succeeds
// or the address does not answer.
std::string handshake_problem(const SslAddress& address) {
  Descriptor socket{connect_within(address, 500)};
  if (socket.fd < 0) return "";
  ERR_clear_error();
  SslContextPtr context(SSL_CTX_new(TLS_client_method()));
  if (!context || SSL_CTX_load_verify_locations(context.get(), g_tls.authority.c_str(), nullptr) != 1 ||
      SSL_CTX_use_certificate_chain_file(context.get(), g_tls.identity.c_str()) != 1 ||
      SSL_CTX_use_PrivateKey_file(context.get(), g_tls.identity.c_str(), SSL_FILETYPE_PEM) != 1)
    return "this process's certificates could not be loaded (" + openssl_error() + ")";
  SSL_CTX_set_verify(context.get(), SSL_VERIFY_PEER, nullptr);
  SslPtr ssl(SSL_new(context.get()));
  SSL_set_fd(ssl.get(), socket.fd);
  if (SSL_connect(ssl.get()) != 1) {
    const long verified = SSL_get_verify_result(ssl.get());
    if (verified != X509_V_OK)
      return std::string("its certificate was not issued by this system's authority (") +
             X509_verify_cert_error_string(verified) + ")";
    return "it refused this process's certificate (" + openssl_error() + ")";
  }
  // TLS 1.3: the server judges the client's certificate after the client's side of the
  // handshake is done, and its alert comes with the first read. A server that accepted it
  // waits for a request: the read times out.
  char byte = 0;
  const int n = SSL_read(ssl.get(), &byte, 1);
  if (n <= 0 && SSL_get_error(ssl.get(), n) == SSL_ERROR_SSL)
    return "it refused this process's certificate (" + openssl_error() + ")";
  ERR_clear_error();
  return "";
}

}  // namespace

std::string tls_handshake_problem(CORBA::Object_ptr object) {
  if (!tls_configured()) return "";
  for (const SslAddress& address : ssl_addresses(object)) {
    if (std::string problem = handshake_problem(address); !problem.empty()) return problem;
  }
  return "";
}

void make_tls_authority(const fs::path& folder, const std::string& system, const std::string& identity_name,
                        int days) {
  check_request(system + " CA", days);
  check_request(identity_name, days);
  make_folder(folder);
  KeyPtr authority_key = new_key(system + " CA");
  X509Ptr authority = new_certificate(authority_key.get(), system + " CA", true, nullptr, nullptr, days);
  {
    const fs::path file = folder / kAuthorityKeyFile;
    FilePtr f = create_file(file, 0600);
    write_private_key(f.get(), authority_key.get(), file);
    close_file(std::move(f), file);
  }
  write_authority_certificate(folder, authority.get());
  write_identity(folder, identity_name, authority.get(), authority_key.get(), days);
}

void issue_tls_identity(const fs::path& authority_folder, const fs::path& folder, const std::string& name, int days) {
  check_request(name, days);
  const fs::path key_file = authority_folder / kAuthorityKeyFile;
  if (!fs::exists(key_file))
    fail(key_file, "no authority key here: identities are issued in the folder `rtm tls init` made");
  check_private(key_file);
  X509Ptr authority = read_certificate(authority_folder / kAuthorityFile);
  KeyPtr authority_key = read_private_key(key_file);
  if (X509_check_private_key(authority.get(), authority_key.get()) != 1)
    fail(key_file, "does not belong to " + (authority_folder / kAuthorityFile).string());
  make_folder(folder);
  write_authority_certificate(folder, authority.get());
  write_identity(folder, name, authority.get(), authority_key.get(), days);
}

}  // namespace rtm
