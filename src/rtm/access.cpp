// SPDX-License-Identifier: Apache-2.0
#include "rtm/access.h"

#include <fcntl.h>
#include <pwd.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <unistd.h>

#include <omniORB4/CORBA.h>
#include <omniORB4/omniInterceptors.h>
// GIOP_S (the request as received) and its service contexts; omniORB ships these headers.
#include <omniORB4/internal/giopStrand.h>
#include <omniORB4/internal/giopStream.h>
#include <omniORB4/internal/GIOP_S.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <stdexcept>
#include <string>

#include "rtm/log.h"

namespace rtm {

namespace {

// A service context id of our own ("RTM" 0); ORBs ignore contexts they do not know.
constexpr CORBA::ULong kKeyContextId = 0x52544d00;

// What the interceptors read: written before the ORB serves (install), then only read.
struct AccessState {
  std::atomic<bool> configured{false};
  std::atomic<bool> registered{false};
  std::atomic<bool> have_key{false};
  std::atomic<AccessPolicy> policy{AccessPolicy::owner};
  AccessKey key{};
  std::atomic<std::uint64_t> refused{0};
  std::atomic<std::uint64_t> refused_data{0};
};
AccessState g_access;

std::string errno_text(int error) { return std::strerror(error); }

std::string home_folder() {
  if (const char* home = std::getenv("HOME"); home && *home) return home;
  if (const passwd* pw = getpwuid(getuid()); pw && pw->pw_dir) return pw->pw_dir;
  throw std::runtime_error("no home folder (HOME unset) for the access key; set RTM_KEY_FILE");
}

std::string parent_of(const std::string& path) {
  const auto slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  return slash == 0 ? "/" : path.substr(0, slash);
}

bool equal_keys(const unsigned char* a, const unsigned char* b) {
  unsigned char diff = 0;  // the same time whatever differs
  for (std::size_t i = 0; i < AccessKey{}.size(); ++i) diff = static_cast<unsigned char>(diff | (a[i] ^ b[i]));
  return diff == 0;
}

void check_private(const std::string& path, const struct stat& st) {
  if (st.st_uid != geteuid()) throw std::runtime_error("access key " + path + " belongs to another user");
  if ((st.st_mode & 077) != 0)
    throw std::runtime_error("access key " + path + " may be read by others (chmod 600 it, or remove it to make a new one)");
}

AccessKey read_key(const std::string& path, int fd) {
  struct stat st {};
  if (fstat(fd, &st) != 0) throw std::runtime_error("cannot stat access key " + path + ": " + errno_text(errno));
  check_private(path, st);
  char hex[2 * AccessKey{}.size() + 2];
  ssize_t got = 0;
  while (got < static_cast<ssize_t>(sizeof hex)) {
    const ssize_t n = ::read(fd, hex + got, sizeof hex - static_cast<std::size_t>(got));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    got += n;
  }
  AccessKey key{};
  if (got < static_cast<ssize_t>(2 * key.size()))
    throw std::runtime_error("access key " + path + " is not 64 hexadecimal digits (remove it to make a new one)");
  for (std::size_t i = 0; i < key.size(); ++i) {
    unsigned value = 0;
    for (int k = 0; k < 2; ++k) {
      const char c = hex[2 * i + static_cast<std::size_t>(k)];
      const int digit = (c >= '0' && c <= '9') ? c - '0' : (c >= 'a' && c <= 'f') ? c - 'a' + 10 : -1;
      if (digit < 0)
        throw std::runtime_error("access key " + path + " is not 64 hexadecimal digits (remove it to make a new one)");
      value = value * 16 + static_cast<unsigned>(digit);
    }
    key[i] = static_cast<unsigned char>(value);
  }
  return key;
}

// Writes a new key to a private temporary file and links it to `path`: a reader never sees a
// part-written key, and of two processes starting together one key wins (EEXIST for the other,
// which then reads the winner's).
void make_key(const std::string& path) {
  const std::string temporary = path + ".new." + std::to_string(getpid());
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC | O_NOFOLLOW, 0600);
  if (fd < 0) throw std::runtime_error("cannot make access key " + path + ": " + errno_text(errno));
  AccessKey key{};
  bool written = getrandom(key.data(), key.size(), 0) == static_cast<ssize_t>(key.size());
  const int random_error = errno;
  char hex[2 * AccessKey{}.size() + 1];
  for (std::size_t i = 0; i < key.size(); ++i) std::snprintf(hex + 2 * i, 3, "%02x", key[i]);
  hex[sizeof hex - 1] = '\n';
  written = written && ::write(fd, hex, sizeof hex) == static_cast<ssize_t>(sizeof hex) && ::fsync(fd) == 0;
  const int write_error = errno;
  ::close(fd);
  if (!written) {
    ::unlink(temporary.c_str());
    throw std::runtime_error("cannot write access key " + path + ": " + errno_text(random_error ? random_error : write_error));
  }
  const bool linked = ::link(temporary.c_str(), path.c_str()) == 0;
  const int link_error = errno;
  ::unlink(temporary.c_str());
  if (!linked && link_error != EEXIST)
    throw std::runtime_error("cannot make access key " + path + ": " + errno_text(link_error));
}

CORBA::Boolean add_key(omni::omniInterceptors::clientSendRequest_T::info_T& info) {
  if (!g_access.have_key.load(std::memory_order_acquire)) return true;
  const CORBA::ULong n = info.service_contexts.length();
  info.service_contexts.length(n + 1);
  IOP::ServiceContext& context = info.service_contexts[n];
  context.context_id = kKeyContextId;
  // Refers to the key in place: no copy, no allocation per request.
  context.context_data.replace(g_access.key.size(), g_access.key.size(), g_access.key.data(), false);
  return true;
}

bool carries_our_key(omni::GIOP_S& request) {
  if (!g_access.have_key.load(std::memory_order_acquire)) return false;
  const IOP::ServiceContextList& contexts = request.service_contexts();
  for (CORBA::ULong i = 0; i < contexts.length(); ++i) {
    const IOP::ServiceContext& context = contexts[i];
    if (context.context_id != kKeyContextId || context.context_data.length() != g_access.key.size()) continue;
    if (equal_keys(context.context_data.get_buffer(), g_access.key.data())) return true;
  }
  return false;
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
void note_refusal(std::atomic<std::uint64_t>& count, omni::omniInterceptors::serverReceiveRequest_T::info_T& info,
                  const std::string& why) {
  const std::uint64_t refused = count.fetch_add(1, std::memory_order_relaxed) + 1;
  if (refused > 3 && refused % 1000 != 0) return;
  const char* peer = info.peeraddress();
  log().warn("refused {} from {}: {} ({} refused so far)", info.operation(), peer ? peer : "?", why, refused);
}

// A request over a giop:ssl: connection whose peer certificate omniORB verified against this
// process's authority (rtm/tls.h): omniORB sets the peer identity only for a verified peer.
bool from_verified_tls_peer(omni::omniInterceptors::serverReceiveRequest_T::info_T& info) {
  const char* address = info.peeraddress();
  if (!address || std::strncmp(address, "giop:ssl:", 9) != 0) return false;
  const char* identity = info.peeridentity();
  return identity && *identity;
}

// Both checks throw before the arguments are read: the request body is skipped, not unmarshalled.
CORBA::Boolean check_key(omni::omniInterceptors::serverReceiveRequest_T::info_T& info) {
  const char* operation = info.operation();
  if (!operation) return true;
  if (is_put_operation(operation)) {
    const std::optional<CORBA::ULong> kind = first_typecode_kind(info.giop_s);
    if (kind && !plain_data_kind(*kind)) {
      note_refusal(g_access.refused_data, info,
                   "the datum's type (TypeCode kind " + std::to_string(*kind) + ") is no data type");
      throw CORBA::BAD_PARAM(kNotPlainDataMinor, CORBA::COMPLETED_NO);
    }
  }
  if (g_access.policy.load(std::memory_order_acquire) == AccessPolicy::open) return true;
  if (!is_change_operation(operation)) return true;
  if (carries_our_key(info.giop_s) || from_verified_tls_peer(info)) return true;
  note_refusal(g_access.refused, info, "it does not carry this component owner's access key");
  throw CORBA::NO_PERMISSION(kAccessRefusedMinor, CORBA::COMPLETED_NO);
}

}  // namespace

std::optional<AccessPolicy> parse_access_policy(std::string_view text) {
  if (text == "owner") return AccessPolicy::owner;
  if (text == "open") return AccessPolicy::open;
  return std::nullopt;
}

std::string access_key_path() {
  if (const char* file = std::getenv("RTM_KEY_FILE"); file && *file) return file;
  return home_folder() + "/.rtm/key";
}

AccessKey load_or_make_access_key() {
  const std::string path = access_key_path();
  const std::string folder = parent_of(path);
  if (::mkdir(folder.c_str(), 0700) != 0 && errno != EEXIST)
    throw std::runtime_error("cannot make the access key's folder " + folder + ": " + errno_text(errno));
  for (int attempt = 0; attempt < 2; ++attempt) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
    if (fd >= 0) {
      try {
        AccessKey key = read_key(path, fd);
        ::close(fd);
        return key;
      } catch (...) {
        ::close(fd);
        throw;
      }
    }
    if (errno != ENOENT) throw std::runtime_error("cannot read access key " + path + ": " + errno_text(errno));
    make_key(path);  // or another process just did: read it on the next round either way
  }
  throw std::runtime_error("access key " + path + " appeared and vanished while being read");
}

void configure_default_access() {
  if (g_access.configured.load()) return;
  std::optional<AccessKey> key;
  try {
    key = load_or_make_access_key();
  } catch (const std::exception& e) {
    log().debug("no access key: {}; this process can read components but change none", e.what());
  }
  configure_access(key, AccessPolicy::owner);
}

void configure_access(const std::optional<AccessKey>& key, AccessPolicy policy) {
  if (key) g_access.key = *key;
  g_access.have_key.store(key.has_value(), std::memory_order_release);
  g_access.policy.store(policy, std::memory_order_release);
  g_access.configured.store(true);
}

void register_access_interceptors() {
  if (g_access.registered.exchange(true)) return;
  omniORB::getInterceptors()->clientSendRequest.add(add_key);
  omniORB::getInterceptors()->serverReceiveRequest.add(check_key);
}

bool is_change_operation(std::string_view name) {
  static constexpr std::string_view kChanges[] = {"on",        "off",         "reset",        "set_parameter",
                                                  "subscribe", "unsubscribe", "put",          "push",
                                                  "put_in_order", "push_in_order", "hold",
                                                  "release"};
  for (std::string_view change : kChanges)
    if (name == change) return true;
  return false;
}

}  // namespace rtm
