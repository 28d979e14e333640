// SPDX-License-Identifier: Apache-2.0
#include "rtm_test/raw_giop.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
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
                                      const std::vector<std::uint8_t>& body, int timeout_ms) {
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
  header.ulong(0);  // no service contexts
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

}  // namespace rtm_test
