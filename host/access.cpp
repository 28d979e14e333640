// SPDX-License-Identifier: Apache-2.0
#include "host/access.h"

#include <pthread.h>
#include <pwd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <omniORB4/CORBA.h>
#include <omniORB4/omniInterceptors.h>
#include <omniORB4/sslContext.h>
#include <omniORB4/sslConnection.h>
#include <openssl/ssl.h>
#include <openssl/x509.h>
// The strand and its connection, GIOP_S/GIOP_C (a request as received or sent, streams on a
// strand), the socket under a connection: omniORB ships these headers, which must come in
// this order.
// clang-format off
#include <omniORB4/internal/giopStrand.h>
#include <omniORB4/internal/giopStream.h>
#include <omniORB4/internal/GIOP_C.h>
#include <omniORB4/internal/GIOP_S.h>
#include <omniORB4/internal/SocketCollection.h>
// clang-format on

#include <fmt/format.h>

#include <atomic>
#include <cstring>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>

#include "host/socket_peer.h"
#include "rt/thread.h"
#include "rtm/log.h"
#include "rtm/orb.h"

namespace rtm {

namespace {

struct AccessState {
  std::atomic<bool> registered{false};
  std::atomic<AccessPolicy> policy{AccessPolicy::owner};
  std::atomic<std::uint64_t> refused{0};
  std::atomic<std::uint64_t> refused_data{0};
};
AccessState g_access;

// omniORB keeps a connection's socket in SocketHolder::pd_socket (protected): a pointer to
// that member, formed through a class derived from it, reads it from any SocketHolder.
struct SocketOf : omni::SocketHolder {
  static omni::SocketHandle_t of(omni::SocketHolder& holder) { return holder.*(&SocketOf::pd_socket); }
};

bool starts_with(const char* text, const char* prefix) {
  return text && std::strncmp(text, prefix, std::strlen(prefix)) == 0;
}

int socket_of(omni::giopConnection& connection) {
  auto* holder = dynamic_cast<omni::SocketHolder*>(&connection);
  return holder ? SocketOf::of(*holder) : -1;
}

// The certificate the peer of a giop:ssl: connection presented and this process verified against
// its authority in the handshake (both sides of omniORB's handshake require one), or nullptr.
X509* verified_certificate(omni::giopConnection& connection) {
  auto* tls = dynamic_cast<omni::sslConnection*>(&connection);
  SSL* ssl = tls ? tls->ssl_handle() : nullptr;
  if (!ssl) return nullptr;
  X509* certificate = SSL_get0_peer_certificate(ssl);
  return certificate && SSL_get_verify_result(ssl) == X509_V_OK ? certificate : nullptr;
}

// That certificate's common name ("op@hostb"), "" when there is none.
std::string verified_identity(omni::giopConnection& connection) {
  X509* certificate = verified_certificate(connection);
  if (!certificate) return "";
  X509_NAME* subject = X509_get_subject_name(certificate);
  const int at = X509_NAME_get_index_by_NID(subject, NID_commonName, -1);
  if (at < 0) return "";
  unsigned char* text = nullptr;
  const int length = ASN1_STRING_to_UTF8(&text, X509_NAME_ENTRY_get_data(X509_NAME_get_entry(subject, at)));
  if (length < 0) return "";
  std::string identity(reinterpret_cast<const char*>(text), static_cast<std::size_t>(length));
  OPENSSL_free(text);
  return identity;
}

Peer peer_of_connection(omni::giopConnection* connection) {
  Peer peer;
  if (!connection) return peer;
  const char* address = connection->peeraddress();
  peer.address = address ? address : "";
  if (starts_with(address, "giop:ssl:")) {
    peer.transport = Transport::tls;
    peer.identity = verified_identity(*connection);
    return peer;
  }
  if (starts_with(address, "giop:unix:")) {
    peer.transport = Transport::unix_socket;
  } else if (starts_with(address, "giop:tcp:")) {
    peer.transport = Transport::tcp;
  } else {
    return peer;
  }
  if (const auto found = socket_peer(socket_of(*connection))) {
    peer.uid = found->uid;
    peer.pid = found->pid;
    peer.socket_inode = found->inode;
  }
  return peer;
}

// The user behind each connection of this process's servers, as the kernel said when the
// connection was accepted (a TCP peer is looked up in /proc/net/tcp once, not per request). A
// connection's entry is written when it is accepted, before any request on it, so an entry
// left by a closed connection whose memory a new one reuses is overwritten first; one not
// found (the table was emptied at its bound) is asked of the kernel again.
class Callers {
 public:
  struct Caller {
    bool known = false;  // the kernel named the user (unix socket, TCP from this host)
    uid_t uid = 0;
  };
  static Caller from(const Peer& peer) { return peer.uid ? Caller{true, *peer.uid} : Caller{}; }

  void accepted(const omni::giopConnection* connection, Caller caller) {
    std::lock_guard lock(mutex_);
    if (by_connection_.size() >= kBound) by_connection_.clear();
    by_connection_[connection] = caller;
  }
  void forget(const omni::giopConnection* connection) {
    std::lock_guard lock(mutex_);
    by_connection_.erase(connection);
  }
  Caller of(omni::giopConnection* connection) {
    {
      std::lock_guard lock(mutex_);
      if (const auto it = by_connection_.find(connection); it != by_connection_.end()) return it->second;
    }
    const Caller caller = from(peer_of_connection(connection));
    accepted(connection, caller);
    return caller;
  }

 private:
  static constexpr std::size_t kBound = 4096;
  std::mutex mutex_;
  std::unordered_map<const omni::giopConnection*, Caller> by_connection_;
};
Callers g_callers;

CORBA::Boolean note_caller(omni::omniInterceptors::serverAcceptConnection_T::info_T& info) {
  omni::giopConnection* connection = info.strand.connection;
  if (!connection || starts_with(connection->peeraddress(), "giop:ssl:")) return true;
  if (g_access.policy.load(std::memory_order_relaxed) == AccessPolicy::open) {
    g_callers.forget(connection);  // nothing to check now; asked of the kernel if that changes
  } else {
    g_callers.accepted(connection, Callers::from(peer_of_connection(connection)));
  }
  return true;
}

// The kind of the first argument's TypeCode (put's any) read in place from the request buffer,
// without consuming it: nullopt when it is not in the buffer.
struct StreamWindow : cdrStream {
  static void* end(cdrStream& s) { return static_cast<StreamWindow&>(s).pd_inb_end; }
  static bool swapped(cdrStream& s) { return static_cast<StreamWindow&>(s).pd_unmarshal_byte_swap; }
};

std::optional<CORBA::ULong> first_typecode_kind(omni::GIOP_S& request) {
  cdrStream& stream = request.getStream();
  auto p = reinterpret_cast<omni::ptr_arith_t>(stream.inPtr());
  const GIOP::Version version = request.version();
  if (version.major == 1 && version.minor >= 2) p = omni::align_to(p, omni::ALIGN_8);  // the body
  p = omni::align_to(p, omni::ALIGN_4);
  if (reinterpret_cast<void*>(p + 4) > StreamWindow::end(stream)) return std::nullopt;
  CORBA::ULong kind = 0;
  std::memcpy(&kind, reinterpret_cast<const void*>(p), sizeof kind);
  return StreamWindow::swapped(stream) ? __builtin_bswap32(kind) : kind;
}

// A datum is plain data: an any holding an any (whose unmarshalling omniORB 4.2 does in time
// that doubles per level), an object reference, a value type or a TypeCode never is.
bool plain_data_kind(CORBA::ULong kind) {
  switch (static_cast<CORBA::TCKind>(kind)) {
    case CORBA::tk_any:
    case CORBA::tk_objref:
    case CORBA::tk_TypeCode:
    case CORBA::tk_Principal:
    case CORBA::tk_value:
    case CORBA::tk_value_box:
    case CORBA::tk_native:
    case CORBA::tk_abstract_interface:
    case CORBA::tk_local_interface: return false;
    default: return kind <= static_cast<CORBA::ULong>(CORBA::tk_local_interface);  // 0xffffffff: indirection
  }
}

bool is_put_operation(std::string_view name) {
  return name == "put" || name == "push" || name == "put_in_order" || name == "push_in_order";
}

// Counts a refusal and logs the first three, then every thousandth.
void note_refusal(std::atomic<std::uint64_t>& count, omni::GIOP_S& request, const char* operation,
                  const std::string& why) {
  const std::uint64_t refused = count.fetch_add(1, std::memory_order_relaxed) + 1;
  if (refused > 3 && refused % 1000 != 0) return;
  const Peer peer = peer_of_connection(request.strand().connection);
  const std::string who = peer.uid ? fmt::format(" (uid {})", *peer.uid) : "";
  log().warn("refused {} from {}{}: {} ({} refused so far)", operation, peer.address.empty() ? "?" : peer.address, who,
             why, refused);
}

// The thread serving a request runs at the real-time path's priority (rt/thread.h) while it
// carries a put the screen let through from a caller it knows (this user's process, a peer
// with a certificate of this process's authority): a datum that comes over CORBA passes no
// thread at SCHED_OTHER. Every other request (a read from anyone, a change that is no put, any
// request when the component is open to all) runs at SCHED_OTHER, so that nobody who may only
// read can keep a real-time thread busy, and an admitted put costs what the screen bounds.
// A system call only when the kind changes: a connection that carries only puts (omniORB
// serves each connection on a thread of its own) makes none.
void serve_at_path_priority(bool admitted_put) {
  thread_local int t_priority = 0;  // this thread's now; ORB threads start at SCHED_OTHER
  const int wanted = admitted_put ? path_thread_priority() : 0;
  if (wanted == t_priority) return;
  if (set_thread_fifo_priority(pthread_self(), wanted) == 0) t_priority = wanted;
}

// Both checks throw before the arguments are read: the request body is skipped, not
// unmarshalled. Returns true for a put from a caller the screen knows (see above).
bool admit_request(omni::omniInterceptors::serverReceiveRequest_T::info_T& info, const char* operation) {
  const bool put = is_put_operation(operation);
  if (put) {
    const std::optional<CORBA::ULong> kind = first_typecode_kind(info.giop_s);
    if (kind && !plain_data_kind(*kind)) {
      note_refusal(g_access.refused_data, info.giop_s, operation,
                   "the datum's type (TypeCode kind " + std::to_string(*kind) + ") is no data type");
      throw CORBA::BAD_PARAM(kNotPlainDataMinor, CORBA::COMPLETED_NO);
    }
  }
  if (g_access.policy.load(std::memory_order_relaxed) == AccessPolicy::open) return false;
  if (!is_change_operation(operation)) return false;
  omni::giopConnection* connection = info.giop_s.strand().connection;
  if (!connection) throw CORBA::NO_PERMISSION(kCallerUnknownMinor, CORBA::COMPLETED_NO);
  // A certificate this process's authority issued, which omniORB verified in the handshake.
  if (starts_with(connection->peeraddress(), "giop:ssl:")) {
    if (verified_certificate(*connection)) return put;
    note_refusal(g_access.refused, info.giop_s, operation, "its TLS connection carries no verified certificate");
    throw CORBA::NO_PERMISSION(kCallerUnknownMinor, CORBA::COMPLETED_NO);
  }
  const Callers::Caller caller = g_callers.of(connection);
  if (caller.known && is_owner_uid(caller.uid)) return put;
  if (caller.known) {
    note_refusal(g_access.refused, info.giop_s, operation, "the caller is not this component's user");
    throw CORBA::NO_PERMISSION(kAccessRefusedMinor, CORBA::COMPLETED_NO);
  }
  note_refusal(g_access.refused, info.giop_s, operation, "who calls from another host over plain TCP is unknown");
  throw CORBA::NO_PERMISSION(kCallerUnknownMinor, CORBA::COMPLETED_NO);
}

CORBA::Boolean screen_request(omni::omniInterceptors::serverReceiveRequest_T::info_T& info) {
  const char* operation = info.operation();
  bool admitted_put = false;
  try {
    admitted_put = operation != nullptr && admit_request(info, operation);
  } catch (...) {
    serve_at_path_priority(false);  // a refusal is answered at SCHED_OTHER
    throw;
  }
  serve_at_path_priority(admitted_put);
  return true;
}

// peer_of(): the thread's call whose connection is wanted, and what was found.
struct Capture {
  bool wanted = false;
  std::optional<Peer> peer;
};
thread_local Capture t_capture;

CORBA::Boolean capture_peer(omni::omniInterceptors::clientReceiveReply_T::info_T& info) {
  if (t_capture.wanted) t_capture.peer = peer_of_connection(info.giop_c.strand().connection);
  return true;
}

}  // namespace

std::optional<AccessPolicy> parse_access_policy(std::string_view text) {
  if (text == "owner") return AccessPolicy::owner;
  if (text == "open") return AccessPolicy::open;
  return std::nullopt;
}

void configure_access(AccessPolicy policy) {
  g_access.policy.store(policy, std::memory_order_relaxed);
  process_hooks().after_orb_init = register_access_interceptors;
}

void register_access_interceptors() {
  if (g_access.registered.exchange(true)) return;
  omniORB::getInterceptors()->serverAcceptConnection.add(note_caller);
  omniORB::getInterceptors()->serverReceiveRequest.add(screen_request);
  omniORB::getInterceptors()->clientReceiveReply.add(capture_peer);
}

bool is_change_operation(std::string_view name) {
  static constexpr std::string_view kChanges[] = {"on",           "off",           "reset", "set_parameter",
                                                  "subscribe",    "unsubscribe",   "put",   "push",
                                                  "put_in_order", "push_in_order", "hold",  "release",
                                                  "admit_writer", "attach_ring",   "detach_ring", "connect"};
  for (std::string_view change : kChanges)
    if (name == change) return true;
  return false;
}

bool is_owner_uid(uid_t uid) { return uid == ::geteuid() || uid == 0; }

std::optional<Peer> peer_of(CORBA::Object_ptr object) {
  struct Reset {
    ~Reset() { t_capture = Capture{}; }
  } reset;
  t_capture = Capture{};
  t_capture.wanted = true;
  (void)object->_non_existent();
  return t_capture.peer;
}

}  // namespace rtm
