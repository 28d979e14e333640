// SPDX-License-Identifier: Apache-2.0
// rtm serve's gate, the parts that need no socket: a request read as far as it has arrived (as
// httplib reads it), and the owner of a TCP peer found in /proc/net/tcp and tcp6.
#include "serve_gate.h"

#include <arpa/inet.h>
#include <gtest/gtest.h>

#include <string>

namespace {

using rtm::cli::ArrivedRequest;
using rtm::cli::read_arrived;
using rtm::cli::socket_owner;
using State = ArrivedRequest::State;

constexpr std::size_t kHead = 16 * 1024, kBody = 1024 * 1024;

TEST(ReadArrived, AHeadWithoutItsEmptyLineIsStillArrivingAndSoIsABodyShortOfItsLength) {
  EXPECT_EQ(read_arrived("GET /api/system HTTP/1.1\r\nHost: 127.0.0.1:1\r\n", kHead, kBody).state, State::incomplete);
  const std::string post = "POST /api/connect HTTP/1.1\r\nHost: h\r\nContent-Length: 10\r\n\r\n";
  EXPECT_EQ(read_arrived(post + "12345", kHead, kBody).state, State::incomplete);
  const ArrivedRequest whole = read_arrived(post + "1234567890", kHead, kBody);
  ASSERT_EQ(whole.state, State::complete);
  EXPECT_EQ(whole.size, post.size() + 10);
}

TEST(ReadArrived, ThePathIsDecodedAndTheQueryParsedAsHttplibDoes) {
  const ArrivedRequest r = read_arrived(
      "GET /api/components/a%5Cb/off?token=abc&page=p1 HTTP/1.1\r\nHost: 127.0.0.1:8\r\nX-RTM-Token:  t0k \r\n\r\n", kHead,
      kBody);
  ASSERT_EQ(r.state, State::complete) << r.why;
  EXPECT_EQ(r.request.method, "GET");
  EXPECT_EQ(r.request.path, "/api/components/a\\b/off");
  EXPECT_EQ(r.request.get_param_value("token"), "abc");
  EXPECT_EQ(r.request.get_param_value("page"), "p1");
  EXPECT_EQ(r.request.get_header_value("x-rtm-token"), "t0k");
  EXPECT_EQ(read_arrived("GET /api/components/a%2Fb/on HTTP/1.1\r\n\r\n", kHead, kBody).request.path,
            "/api/components/a/b/on");
}

TEST(ReadArrived, AMalformedOrOversizedRequestIsRefusedWithItsStatusAndASentence) {
  const auto refused = [](const std::string& bytes, std::size_t head = kHead, std::size_t body = kBody) {
    return read_arrived(bytes, head, body);
  };
  EXPECT_EQ(refused("HELLO\r\n\r\n").status, 400);
  EXPECT_EQ(refused("GET / HTTP/2\r\n\r\n").status, 400);
  EXPECT_EQ(refused("BREW / HTTP/1.1\r\n\r\n").status, 400);
  EXPECT_EQ(refused("GET / HTTP/1.1\r\nno colon here\r\n\r\n").status, 400);
  EXPECT_EQ(refused("POST / HTTP/1.1\r\nContent-Length: 1x\r\n\r\n").status, 400);
  EXPECT_EQ(refused("POST / HTTP/1.1\r\nContent-Length: 1\r\nContent-Length: 2\r\n\r\n").status, 400);
  EXPECT_EQ(refused("POST / HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n").status, 411);
  const ArrivedRequest big = refused("POST / HTTP/1.1\r\nContent-Length: 2000\r\n\r\n", kHead, 1000);
  EXPECT_EQ(big.state, State::too_large);
  EXPECT_EQ(big.status, 413);
  EXPECT_NE(big.why.find("more than 1000"), std::string::npos) << big.why;
  EXPECT_EQ(refused("GET / HTTP/1.1\r\nX: " + std::string(200, 'a'), 100).status, 431) << "no end of head in sight";
  EXPECT_EQ(refused("GET / HTTP/1.1\r\nX: " + std::string(200, 'a') + "\r\n\r\n", 100).status, 431);
}

sockaddr_storage v4(const char* address, int port) {
  sockaddr_storage s{};
  auto& a = reinterpret_cast<sockaddr_in&>(s);
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  inet_pton(AF_INET, address, &a.sin_addr);
  return s;
}

sockaddr_storage v6(const char* address, int port) {
  sockaddr_storage s{};
  auto& a = reinterpret_cast<sockaddr_in6&>(s);
  a.sin6_family = AF_INET6;
  a.sin6_port = htons(static_cast<std::uint16_t>(port));
  inet_pton(AF_INET6, address, &a.sin6_addr);
  return s;
}

// Lines as Linux 6 prints them (a listener, the server's end, the client's end).
constexpr const char* kTcp =
    "  sl  local_address rem_address   st tx_queue rx_queue tr tm->when retrnsmt   uid  timeout inode\n"
    "   0: 0100007F:1F90 00000000:0000 0A 00000000:00000000 00:00000000 00000000  1000        0 1 1 0 100 0 0 10 0\n"
    "   1: 0100007F:1F90 0100007F:D431 01 00000000:00000000 00:00000000 00000000  1000        0 2 1 0 20 4 30 10 -1\n"
    "   2: 0100007F:D431 0100007F:1F90 01 00000000:00000000 00:00000000 00000000 65534        0 3 1 0 20 4 30 10 -1\n";

TEST(SocketOwner, TheClientsEndOfAConnectionIsFoundByBothItsEndsNotTheServersEnd) {
  // The server (port 8080, uid 1000) accepted 127.0.0.1:54321, which user 65534 connected.
  EXPECT_EQ(socket_owner(kTcp, v4("127.0.0.1", 54321), v4("127.0.0.1", 8080)), 65534u);
  EXPECT_EQ(socket_owner(kTcp, v4("127.0.0.1", 8080), v4("127.0.0.1", 54321)), 1000u);
  EXPECT_EQ(socket_owner(kTcp, v4("127.0.0.1", 54322), v4("127.0.0.1", 8080)), std::nullopt);
  EXPECT_EQ(socket_owner("", v4("127.0.0.1", 54321), v4("127.0.0.1", 8080)), std::nullopt);
}

TEST(SocketOwner, AnIpv6LoopbackPeerIsFoundInTcp6) {
  constexpr const char* tcp6 =
      "  sl  local_address                         remote_address                        st tx_queue rx_queue tr "
      "tm->when retrnsmt   uid  timeout inode\n"
      "   0: 00000000000000000000000001000000:D431 00000000000000000000000001000000:1F90 01 00000000:00000000 "
      "00:00000000 00000000    42        0 3 1 0 20 4 30 10 -1\n";
  EXPECT_EQ(socket_owner(tcp6, v6("::1", 54321), v6("::1", 8080)), 42u);
  EXPECT_EQ(socket_owner(tcp6, v6("::1", 54321), v6("::1", 8081)), std::nullopt);
}

}  // namespace
