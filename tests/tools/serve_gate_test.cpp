// SPDX-License-Identifier: Apache-2.0
// rtm serve's gate: a request read as far as it has arrived, as httplib reads it; the user at the
// other end of a loopback connection, as the kernel says.
#include "serve/serve_gate.h"

#include <gtest/gtest.h>
#include <grp.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <string>

namespace {

using rtm::cli::ArrivedRequest;
using rtm::cli::peer_user;
using rtm::cli::read_arrived;
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


// A listening socket on 127.0.0.1 (any port) and its address.
int listen_on_loopback(sockaddr_in& address) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  address = {};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t size = sizeof address;
  if (::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0 || ::listen(fd, 4) != 0 ||
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &size) != 0)
    ADD_FAILURE() << "no loopback listener";
  return fd;
}

TEST(PeerUser, BothEndsOfALoopbackConnectionOfThisProcessAreThisUsers) {
  sockaddr_in address{};
  const int listener = listen_on_loopback(address);
  const int client = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  ASSERT_EQ(::connect(client, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
  const int server = ::accept(listener, nullptr, nullptr);
  ASSERT_GE(server, 0);
  EXPECT_EQ(peer_user(server), ::geteuid());
  EXPECT_EQ(peer_user(client), ::geteuid());
  const int unconnected = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  EXPECT_EQ(peer_user(unconnected), std::nullopt);
  for (int fd : {listener, client, server, unconnected}) ::close(fd);
}

// What the server refuses: a peer another user connected. Needs root, to connect as nobody.
TEST(PeerUser, AConnectionAnotherUserMadeIsThatUsers) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root, to connect as another user (nobody)";
  sockaddr_in address{};
  const int listener = listen_on_loopback(address);
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {  // only async-signal-safe calls from here
    ::alarm(10);
    if (::setgroups(0, nullptr) != 0 || ::setgid(65534) != 0 || ::setuid(65534) != 0) ::_exit(2);
    const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) ::_exit(3);
    char byte;
    [[maybe_unused]] const auto n = ::read(fd, &byte, 1);  // until the test closes its end
    ::_exit(0);
  }
  const int server = ::accept(listener, nullptr, nullptr);
  ASSERT_GE(server, 0);
  EXPECT_EQ(peer_user(server), 65534u);
  ::close(server);
  ::close(listener);
  int status = 0;
  ::waitpid(pid, &status, 0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;
}

}  // namespace
