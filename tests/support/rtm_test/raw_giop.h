// SPDX-License-Identifier: Apache-2.0
// A GIOP 1.2 peer written from the specification, for requests an ORB will not send: a request
// built byte by byte goes to an object's IIOP endpoint over TCP and its reply is read back. What
// the tests of the request screen (host/access.h) send as a hostile client would.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace rtm_test {

// The IIOP profile of a stringified IOR ("IOR:..."): where the object listens, its key.
struct IiopProfile {
  std::string host;
  std::uint16_t port = 0;
  std::vector<std::uint8_t> object_key;
};
// Throws std::runtime_error when the text is no IOR or has no IIOP profile.
IiopProfile iiop_profile(const std::string& ior);

// CDR, little endian, alignment counted from the start of the buffer.
class CdrWriter {
 public:
  void octet(std::uint8_t v) { bytes_.push_back(v); }
  void ulong(std::uint32_t v);
  void align(std::size_t n);
  void octets(const std::vector<std::uint8_t>& v);  // sequence<octet>
  void string(const std::string& s);
  const std::vector<std::uint8_t>& bytes() const { return bytes_; }

 private:
  std::vector<std::uint8_t> bytes_;
};

struct GiopReply {
  std::uint32_t status = 0;  // 0 no exception, 1 user exception, 2 system exception, ...
  std::string exception;     // repository id of the exception, when status is 1 or 2
  std::uint32_t minor = 0;   // system exception only
  std::uint32_t completed = 0;
};

struct ServiceContext {
  std::uint32_t id = 0;
  std::vector<std::uint8_t> data;
  auto operator<=>(const ServiceContext&) const = default;
};

// Sends one GIOP 1.2 Request for `operation` with `body` (CDR little endian, written as if
// starting at an 8-aligned offset) and `contexts`, and waits up to timeout_ms for the reply.
// nullopt when the peer closed the connection or did not answer in time.
std::optional<GiopReply> giop_request(const IiopProfile& target, const std::string& operation,
                                      const std::vector<std::uint8_t>& body, int timeout_ms,
                                      const std::vector<ServiceContext>& contexts = {});

// A bait an attacker binds a name to: an IIOP endpoint on 127.0.0.1 (a free port) that records
// the operation and the service contexts of every GIOP 1.2 Request it is sent, and answers each
// with OBJECT_NOT_EXIST (a LocateRequest with UNKNOWN_OBJECT). Its reference:
// "corbaloc::1.2@127.0.0.1:<port>/bait". Serves on a thread of its own until destroyed.
class GiopRecorder {
 public:
  struct Request {
    std::string operation;
    std::vector<ServiceContext> contexts;
  };
  GiopRecorder();
  ~GiopRecorder();
  GiopRecorder(const GiopRecorder&) = delete;
  GiopRecorder& operator=(const GiopRecorder&) = delete;

  std::uint16_t port() const { return port_; }
  std::string corbaloc() const;
  std::vector<Request> requests() const;

 private:
  struct State;
  State* state_;
  std::uint16_t port_ = 0;
};

}  // namespace rtm_test
