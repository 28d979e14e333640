// SPDX-License-Identifier: Apache-2.0
#include "rtm_test/raw_giop.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fcntl.h>

#include <chrono>
#include <mutex>
#include <thread>
#include <cstring>
#include <stdexcept>

namespace rtm_test {

namespace {

// Reads CDR from an encapsulation (or a message): byte order from its first octet (or given),
// alignment counted from `base`.
class CdrReader {
 public:
  CdrReader(const std::uint8_t* data, std::size_t size, bool little_endian, std::size_t base = 0)
      : data_(data), size_(size), little_(little_endian), base_(base) {}
  std::uint8_t octet() {
    need(1);
    return data_[at_++];
  }
  std::uint16_t ushort() {
    align(2);
    need(2);
    const std::uint16_t v = little_ ? static_cast<std::uint16_t>(data_[at_] | data_[at_ + 1] << 8)
                                    : static_cast<std::uint16_t>(data_[at_] << 8 | data_[at_ + 1]);
    at_ += 2;
    return v;
  }
  std::uint32_t ulong() {
    align(4);
    need(4);
    std::uint32_t v = 0;
    for (int i = 0; i < 4; ++i) {
      const std::uint32_t byte = data_[at_ + static_cast<std::size_t>(i)];
      v |= little_ ? byte << (8 * i) : byte << (8 * (3 - i));
    }
    at_ += 4;
    return v;
  }
  std::vector<std::uint8_t> octets() {
    const std::uint32_t n = ulong();
    need(n);
    std::vector<std::uint8_t> v(data_ + at_, data_ + at_ + n);
    at_ += n;
    return v;
  }
  std::string string() {
    const std::vector<std::uint8_t> v = octets();
    return v.empty() ? std::string() : std::string(v.begin(), v.end() - 1);  // without the NUL
  }
  void align(std::size_t n) { at_ += (n - (base_ + at_) % n) % n; }
  std::size_t at() const { return at_; }

 private:
  void need(std::size_t n) const {
    if (at_ + n > size_) throw std::runtime_error("CDR data end before the value");
  }
  const std::uint8_t* data_;
  std::size_t size_;
  bool little_;
  std::size_t base_;
  std::size_t at_ = 0;
};

constexpr std::uint32_t kTagInternetIop = 0;

bool read_exactly(int fd, std::uint8_t* buffer, std::size_t size, std::chrono::steady_clock::time_point deadline) {
  std::size_t got = 0;
  while (got < size) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) return false;
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) return false;
    const ssize_t n = ::recv(fd, buffer + got, size - got, 0);
    if (n <= 0) return false;
    got += static_cast<std::size_t>(n);
  }
  return true;
}

}  // namespace

void CdrWriter::ulong(std::uint32_t v) {
  align(4);
  for (int i = 0; i < 4; ++i) bytes_.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}

void CdrWriter::align(std::size_t n) {
  while (bytes_.size() % n != 0) bytes_.push_back(0);
}

void CdrWriter::octets(const std::vector<std::uint8_t>& v) {
  ulong(static_cast<std::uint32_t>(v.size()));
  bytes_.insert(bytes_.end(), v.begin(), v.end());
}

void CdrWriter::string(const std::string& s) {
  ulong(static_cast<std::uint32_t>(s.size() + 1));
  bytes_.insert(bytes_.end(), s.begin(), s.end());
  bytes_.push_back(0);
}

IiopProfile iiop_profile(const std::string& ior) {
  if (ior.rfind("IOR:", 0) != 0 || ior.size() % 2 != 0) throw std::runtime_error("not a stringified IOR");
  std::vector<std::uint8_t> bytes;
  for (std::size_t i = 4; i + 1 < ior.size(); i += 2) bytes.push_back(static_cast<std::uint8_t>(std::stoul(ior.substr(i, 2), nullptr, 16)));
  if (bytes.empty()) throw std::runtime_error("empty IOR");
  CdrReader ior_reader(bytes.data(), bytes.size(), bytes[0] == 1);
  ior_reader.octet();
  ior_reader.string();  // type id
  const std::uint32_t profiles = ior_reader.ulong();
  for (std::uint32_t i = 0; i < profiles; ++i) {
    const std::uint32_t tag = ior_reader.ulong();
    const std::vector<std::uint8_t> data = ior_reader.octets();
    if (tag != kTagInternetIop || data.empty()) continue;
    CdrReader profile(data.data(), data.size(), data[0] == 1);
    profile.octet();
    profile.octet();  // IIOP version
    profile.octet();
    IiopProfile p;
    p.host = profile.string();
    p.port = profile.ushort();
    p.object_key = profile.octets();
    return p;
  }
  throw std::runtime_error("the IOR has no IIOP profile");
}

std::optional<GiopReply> giop_request(const IiopProfile& target, const std::string& operation,
                                      const std::vector<std::uint8_t>& body, int timeout_ms,
                                      const std::vector<ServiceContext>& contexts) {
  CdrWriter header;  // the request header, counted from the start of the message body
  header.ulong(1);   // request id
  header.octet(3);   // response expected
  header.octet(0);
  header.octet(0);
  header.octet(0);
  header.octet(0);  // TargetAddress: KeyAddr (a short, 2-aligned)
  header.octet(0);
  header.octets(target.object_key);
  header.string(operation);
  header.ulong(static_cast<std::uint32_t>(contexts.size()));
  for (const ServiceContext& context : contexts) {
    header.ulong(context.id);
    header.octets(context.data);
  }
  // The request body is 8-aligned in the message; the GIOP header before it is 12 bytes.
  std::vector<std::uint8_t> message_body = header.bytes();
  while ((12 + message_body.size()) % 8 != 0) message_body.push_back(0);
  message_body.insert(message_body.end(), body.begin(), body.end());

  std::vector<std::uint8_t> message{'G', 'I', 'O', 'P', 1, 2, 1 /* little endian */, 0 /* Request */};
  const auto size = static_cast<std::uint32_t>(message_body.size());
  for (int i = 0; i < 4; ++i) message.push_back(static_cast<std::uint8_t>(size >> (8 * i)));
  message.insert(message.end(), message_body.begin(), message_body.end());

  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return std::nullopt;
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(target.port);
  if (::inet_pton(AF_INET, target.host.c_str(), &address.sin_addr) != 1 ||
      ::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0 ||
      ::send(fd, message.data(), message.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(message.size())) {
    ::close(fd);
    return std::nullopt;
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  std::uint8_t reply_header[12];
  std::optional<GiopReply> reply;
  if (read_exactly(fd, reply_header, sizeof reply_header, deadline) && std::memcmp(reply_header, "GIOP", 4) == 0) {
    const bool little = (reply_header[6] & 1) != 0;
    CdrReader size_reader(reply_header + 8, 4, little, 8);
    std::vector<std::uint8_t> reply_body(size_reader.ulong());
    if (read_exactly(fd, reply_body.data(), reply_body.size(), deadline)) {
      CdrReader r(reply_body.data(), reply_body.size(), little, 12);
      GiopReply g;
      r.ulong();  // request id
      g.status = r.ulong();
      const std::uint32_t contexts = r.ulong();
      for (std::uint32_t i = 0; i < contexts; ++i) {
        r.ulong();
        r.octets();
      }
      if (g.status == 1 || g.status == 2) {
        r.align(8);
        g.exception = r.string();
        if (g.status == 2) {
          g.minor = r.ulong();
          g.completed = r.ulong();
        }
      }
      reply = g;
    }
  }
  ::close(fd);
  return reply;
}

// ---------------------------------------------------------------------------------------------
// GiopRecorder
// ---------------------------------------------------------------------------------------------

struct GiopRecorder::State {
  int listener = -1;
  int wake[2] = {-1, -1};
  std::thread thread;
  mutable std::mutex mutex;
  std::vector<Request> requests;
};

namespace {

void send_all(int fd, const std::vector<std::uint8_t>& bytes) {
  (void)::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL);
}

std::vector<std::uint8_t> giop_message(std::uint8_t type, const std::vector<std::uint8_t>& body) {
  std::vector<std::uint8_t> message{'G', 'I', 'O', 'P', 1, 2, 1 /* little endian */, type};
  const auto size = static_cast<std::uint32_t>(body.size());
  for (int i = 0; i < 4; ++i) message.push_back(static_cast<std::uint8_t>(size >> (8 * i)));
  message.insert(message.end(), body.begin(), body.end());
  return message;
}

// One GIOP 1.2 message from a client: records a Request and answers it or a LocateRequest.
void answer(int fd, std::uint8_t type, const std::vector<std::uint8_t>& body, bool little,
            std::vector<GiopRecorder::Request>& requests) {
  CdrReader r(body.data(), body.size(), little, 12);
  const std::uint32_t request_id = r.ulong();
  if (type == 3) {  // LocateRequest
    CdrWriter reply;
    reply.ulong(request_id);
    reply.ulong(0);  // UNKNOWN_OBJECT
    send_all(fd, giop_message(4, reply.bytes()));
    return;
  }
  if (type != 0) return;
  const std::uint8_t flags = r.octet();
  r.octet();
  r.octet();
  r.octet();
  const std::uint16_t disposition = r.ushort();
  if (disposition != 0) return;  // only KeyAddr, as omniORB sends
  r.octets();                    // object key
  GiopRecorder::Request request;
  request.operation = r.string();
  const std::uint32_t contexts = r.ulong();
  for (std::uint32_t i = 0; i < contexts; ++i) {
    ServiceContext context;
    context.id = r.ulong();
    context.data = r.octets();
    request.contexts.push_back(std::move(context));
  }
  requests.push_back(std::move(request));
  if ((flags & 1) == 0) return;  // oneway
  CdrWriter reply;
  reply.ulong(request_id);
  reply.ulong(2);  // SYSTEM_EXCEPTION
  reply.ulong(0);  // no service contexts
  std::vector<std::uint8_t> bytes = reply.bytes();
  while ((12 + bytes.size()) % 8 != 0) bytes.push_back(0);
  CdrWriter exception;
  exception.string("IDL:omg.org/CORBA/OBJECT_NOT_EXIST:1.0");
  exception.ulong(0);  // minor
  exception.ulong(1);  // COMPLETED_NO
  bytes.insert(bytes.end(), exception.bytes().begin(), exception.bytes().end());
  send_all(fd, giop_message(1, bytes));
}

// Reads whatever whole messages a client's connection holds; false when it closed.
bool serve_connection(int fd, std::vector<std::uint8_t>& pending, std::vector<GiopRecorder::Request>& requests) {
  std::uint8_t buffer[4096];
  const ssize_t n = ::recv(fd, buffer, sizeof buffer, 0);
  if (n <= 0) return false;
  pending.insert(pending.end(), buffer, buffer + n);
  while (pending.size() >= 12) {
    if (std::memcmp(pending.data(), "GIOP", 4) != 0) return false;
    const bool little = (pending[6] & 1) != 0;
    CdrReader size_reader(pending.data() + 8, 4, little, 8);
    const std::size_t size = size_reader.ulong();
    if (pending.size() < 12 + size) break;
    const std::vector<std::uint8_t> body(pending.begin() + 12, pending.begin() + 12 + static_cast<std::ptrdiff_t>(size));
    try {
      answer(fd, pending[7], body, little, requests);
    } catch (const std::runtime_error&) {
      // A message this peer cannot read: not answered.
    }
    pending.erase(pending.begin(), pending.begin() + 12 + static_cast<std::ptrdiff_t>(size));
  }
  return true;
}

}  // namespace

GiopRecorder::GiopRecorder() : state_(new State) {
  state_->listener = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t size = sizeof address;
  if (state_->listener < 0 || ::bind(state_->listener, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0 ||
      ::listen(state_->listener, 16) != 0 ||
      ::getsockname(state_->listener, reinterpret_cast<sockaddr*>(&address), &size) != 0 ||
      ::pipe2(state_->wake, O_CLOEXEC) != 0) {
    if (state_->listener >= 0) ::close(state_->listener);
    delete state_;
    throw std::runtime_error("GiopRecorder: cannot listen on 127.0.0.1");
  }
  port_ = ntohs(address.sin_port);
  State* state = state_;
  state_->thread = std::thread([state] {
    std::vector<pollfd> fds{{state->listener, POLLIN, 0}, {state->wake[0], POLLIN, 0}};
    std::vector<std::vector<std::uint8_t>> pending(2);
    for (;;) {
      if (::poll(fds.data(), fds.size(), -1) < 0) continue;
      if (fds[1].revents) break;
      if (fds[0].revents & POLLIN) {
        const int client = ::accept4(state->listener, nullptr, nullptr, SOCK_CLOEXEC);
        if (client >= 0) {
          fds.push_back({client, POLLIN, 0});
          pending.emplace_back();
        }
      }
      for (std::size_t i = 2; i < fds.size();) {
        bool open = true;
        if (fds[i].revents) {
          std::vector<Request> got;
          open = serve_connection(fds[i].fd, pending[i], got);
          std::lock_guard lock(state->mutex);
          for (auto& r : got) state->requests.push_back(std::move(r));
        }
        if (open) {
          fds[i].revents = 0;
          ++i;
          continue;
        }
        ::close(fds[i].fd);
        fds.erase(fds.begin() + static_cast<std::ptrdiff_t>(i));
        pending.erase(pending.begin() + static_cast<std::ptrdiff_t>(i));
      }
    }
    for (std::size_t i = 2; i < fds.size(); ++i) ::close(fds[i].fd);
  });
}

GiopRecorder::~GiopRecorder() {
  (void)::write(state_->wake[1], "x", 1);
  state_->thread.join();
  ::close(state_->listener);
  ::close(state_->wake[0]);
  ::close(state_->wake[1]);
  delete state_;
}

std::string GiopRecorder::corbaloc() const { return "corbaloc::1.2@127.0.0.1:" + std::to_string(port_) + "/bait"; }

std::vector<GiopRecorder::Request> GiopRecorder::requests() const {
  std::lock_guard lock(state_->mutex);
  return state_->requests;
}

}  // namespace rtm_test
