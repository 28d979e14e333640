// SPDX-License-Identifier: Apache-2.0
#include "serve/serve_gate.h"

#include "host/socket_peer.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <fmt/format.h>
#include <netinet/tcp.h>
#include <nlohmann/json.hpp>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/time.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <thread>
#include <vector>

namespace rtm::cli {

namespace {

using clock = std::chrono::steady_clock;

constexpr int kBacklog = 512;                        // httplib listens with 5
constexpr std::chrono::milliseconds kReadTimeout{1000};  // a worker never waits on a request's bytes
constexpr std::size_t kAcceptsPerLook = 64;          // then the connections arriving get a look

void close_now(int fd) {
  ::shutdown(fd, SHUT_RDWR);
  ::close(fd);
}

// The rest of a connection's request, already read by the gate, then the socket itself.
class ConnectionStream final : public httplib::Stream {
 public:
  ConnectionStream(int fd, std::string arrived, std::chrono::milliseconds write_timeout)
      : fd_(fd), arrived_(std::move(arrived)), write_timeout_(write_timeout) {}

  bool is_readable() const override { return read_ < arrived_.size() || wait(POLLIN, clock::now() + kReadTimeout); }
  bool is_writable() const override { return wait(POLLOUT, clock::now() + write_timeout_); }

  ssize_t read(char* ptr, size_t size) override {
    if (read_ < arrived_.size()) {
      const std::size_t n = std::min(size, arrived_.size() - read_);
      std::memcpy(ptr, arrived_.data() + read_, n);
      read_ += n;
      return static_cast<ssize_t>(n);
    }
    if (!wait(POLLIN, clock::now() + kReadTimeout)) return -1;
    ssize_t n;
    do n = ::recv(fd_, ptr, size, MSG_DONTWAIT);
    while (n < 0 && errno == EINTR);
    return n;
  }

  ssize_t write(const char* ptr, size_t size) override {
    const auto deadline = clock::now() + write_timeout_;
    std::size_t sent = 0;
    while (sent < size) {
      const ssize_t n = ::send(fd_, ptr + sent, size - sent, MSG_NOSIGNAL | MSG_DONTWAIT);
      if (n > 0) {
        sent += static_cast<std::size_t>(n);
      } else if (n < 0 && errno == EINTR) {
        continue;
      } else if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
        if (!wait(POLLOUT, deadline)) return -1;
      } else {
        return -1;
      }
    }
    return static_cast<ssize_t>(size);
  }

  void get_remote_ip_and_port(std::string& ip, int& port) const override { address(::getpeername, ip, port); }
  void get_local_ip_and_port(std::string& ip, int& port) const override { address(::getsockname, ip, port); }
  socket_t socket() const override { return fd_; }

 private:
  bool wait(short events, clock::time_point deadline) const {
    for (;;) {
      const auto left = std::chrono::ceil<std::chrono::milliseconds>(deadline - clock::now()).count();
      pollfd p{fd_, events, 0};
      const int n = ::poll(&p, 1, static_cast<int>(std::max<long long>(left, 0)));
      if (n < 0 && errno == EINTR) continue;
      return n > 0 && (p.revents & events) != 0;
    }
  }

  void address(int (*get)(int, sockaddr*, socklen_t*), std::string& ip, int& port) const {
    sockaddr_storage a{};
    socklen_t length = sizeof a;
    if (get(fd_, reinterpret_cast<sockaddr*>(&a), &length) != 0) return;
    char text[INET6_ADDRSTRLEN] = "";
    if (a.ss_family == AF_INET) {
      const auto& v4 = reinterpret_cast<const sockaddr_in&>(a);
      ::inet_ntop(AF_INET, &v4.sin_addr, text, sizeof text);
      port = ntohs(v4.sin_port);
    } else if (a.ss_family == AF_INET6) {
      const auto& v6 = reinterpret_cast<const sockaddr_in6&>(a);
      ::inet_ntop(AF_INET6, &v6.sin6_addr, text, sizeof text);
      port = ntohs(v6.sin6_port);
    }
    ip = text;
  }

  int fd_;
  std::string arrived_;
  std::size_t read_ = 0;
  std::chrono::milliseconds write_timeout_;
};

const char* reason(int status) {
  switch (status) {
    case 200: return "OK";
    case 400: return "Bad Request";
    case 401: return "Unauthorized";
    case 403: return "Forbidden";
    case 404: return "Not Found";
    case 408: return "Request Timeout";
    case 413: return "Payload Too Large";
    case 429: return "Too Many Requests";
    case 431: return "Request Header Fields Too Large";
    case 503: return "Service Unavailable";
    default: return "Refused";
  }
}

ArrivedRequest refused(ArrivedRequest::State state, int status, std::string why) {
  ArrivedRequest r;
  r.state = state;
  r.status = status;
  r.why = std::move(why);
  return r;
}

ArrivedRequest malformed(std::string why) {
  return refused(ArrivedRequest::State::malformed, 400, "refused: " + std::move(why));
}

// The request line as httplib reads it: a known method, the target split at '?' into the
// decoded path and the parsed query (with httplib's own split), HTTP/1.0 or 1.1.
bool read_request_line(std::string_view line, httplib::Request& req) {
  static const std::array<std::string_view, 10> methods{"GET",     "HEAD",    "POST",  "PUT",   "DELETE",
                                                        "CONNECT", "OPTIONS", "TRACE", "PATCH", "PRI"};
  const auto first = line.find(' ');
  const auto second = first == std::string_view::npos ? first : line.find(' ', first + 1);
  if (second == std::string_view::npos || line.find(' ', second + 1) != std::string_view::npos) return false;
  req.method = std::string(line.substr(0, first));
  req.target = std::string(line.substr(first + 1, second - first - 1));
  req.version = std::string(line.substr(second + 1));
  if (std::find(methods.begin(), methods.end(), req.method) == methods.end()) return false;
  if (req.version != "HTTP/1.1" && req.version != "HTTP/1.0") return false;
  std::size_t parts = 0;
  httplib::detail::split(req.target.data(), req.target.data() + req.target.size(), '?',
                         [&](const char* b, const char* e) {
                           if (parts == 0) req.path = httplib::detail::decode_url(std::string(b, e), false);
                           if (parts == 1) httplib::detail::parse_query_text(std::string(b, e), req.params);
                           ++parts;
                         });
  return parts <= 2;
}

// One "Name: value" line as httplib reads it (the value trimmed and URL-decoded).
bool read_header(std::string_view line, httplib::Request& req) {
  while (!line.empty() && (line.back() == ' ' || line.back() == '\t')) line.remove_suffix(1);
  const auto colon = line.find(':');
  if (colon == std::string_view::npos || colon == 0) return false;
  std::string_view value = line.substr(colon + 1);
  while (!value.empty() && (value.front() == ' ' || value.front() == '\t')) value.remove_prefix(1);
  if (value.empty()) return false;
  req.headers.emplace(std::string(line.substr(0, colon)), httplib::detail::decode_url(std::string(value), false));
  return true;
}

}  // namespace

ArrivedRequest read_arrived(std::string_view bytes, std::size_t head_max, std::size_t body_max) {
  const auto end = bytes.find("\r\n\r\n");
  if ((end == std::string_view::npos && bytes.size() > head_max) || (end != std::string_view::npos && end + 4 > head_max))
    return refused(ArrivedRequest::State::too_large, 431,
                   fmt::format("refused: the request's head is longer than {} bytes", head_max));
  if (end == std::string_view::npos) return {};
  ArrivedRequest r;
  const std::string_view head = bytes.substr(0, end + 2);  // each line with its CRLF
  std::size_t at = head.find("\r\n");
  if (!read_request_line(head.substr(0, at), r.request)) return malformed("the request line is not HTTP/1.x");
  for (at += 2; at < head.size();) {
    const auto eol = head.find("\r\n", at);
    if (!read_header(head.substr(at, eol - at), r.request)) return malformed("a header line is not 'Name: value'");
    at = eol + 2;
  }
  if (r.request.has_header("Transfer-Encoding"))
    return refused(ArrivedRequest::State::malformed, 411, "refused: a request body needs a Content-Length");
  std::size_t body = 0;
  if (r.request.has_header("Content-Length")) {
    const std::string length = r.request.get_header_value("Content-Length");
    if (r.request.get_header_value_count("Content-Length") != 1 || length.empty() || length.size() > 12 ||
        !std::all_of(length.begin(), length.end(), [](char c) { return c >= '0' && c <= '9'; }))
      return malformed("Content-Length is not one number");
    body = std::stoull(length);
    if (body > body_max)
      return refused(ArrivedRequest::State::too_large, 413,
                     fmt::format("refused: a request body of {} bytes, more than {}", body, body_max));
  }
  r.size = end + 4 + body;
  r.state = bytes.size() >= r.size ? ArrivedRequest::State::complete : ArrivedRequest::State::incomplete;
  return r;
}

std::optional<uid_t> peer_user(int fd) {
  const auto peer = rtm::socket_peer(fd);
  if (!peer) return std::nullopt;
  return peer->uid;
}

struct GatedServer::Arriving {
  int fd;
  std::string bytes;
  clock::time_point deadline;
};

GatedServer::GatedServer(HandlerWithResponse screen, std::function<Lane(const httplib::Request&)> lane,
                         httplib::Headers headers, Limits limits)
    : screen_(std::move(screen)), lane_(std::move(lane)), headers_(std::move(headers)), limits_(limits) {
  wake_fd_ = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (wake_fd_ < 0) throw std::runtime_error(std::string("rtm serve: eventfd: ") + std::strerror(errno));
  set_default_headers(headers_);
  set_payload_max_length(limits_.body_max);
  set_write_timeout(std::chrono::duration_cast<std::chrono::microseconds>(limits_.write_timeout));
  // The screen again, where httplib reads the request a second time: what the gate let
  // through still meets the same rules.
  set_pre_routing_handler(screen_);
}

GatedServer::~GatedServer() { ::close(wake_fd_); }

void GatedServer::stop_serving() {
  stopping_.store(true);
  const std::uint64_t one = 1;
  [[maybe_unused]] const auto written = ::write(wake_fd_, &one, sizeof one);
}

void GatedServer::serve() {
  const int listener = svr_sock_;
  if (listener == INVALID_SOCKET) throw std::logic_error("GatedServer::serve() before a bind");
  ::fcntl(listener, F_SETFL, ::fcntl(listener, F_GETFL) | O_NONBLOCK);
  ::listen(listener, kBacklog);  // again: a longer backlog than httplib's
  control_ = std::make_unique<httplib::ThreadPool>(limits_.control_workers);
  general_ = std::make_unique<httplib::ThreadPool>(limits_.general_workers);
  std::vector<Arriving> arriving;
  std::vector<pollfd> fds;
  while (!stopping_.load()) {
    fds.assign({pollfd{wake_fd_, POLLIN, 0}, pollfd{listener, POLLIN, 0}});
    auto next = clock::now() + std::chrono::seconds(1);
    for (const auto& a : arriving) {
      fds.push_back({a.fd, POLLIN, 0});
      next = std::min(next, a.deadline);
    }
    const auto wait = std::chrono::ceil<std::chrono::milliseconds>(next - clock::now()).count();
    if (::poll(fds.data(), fds.size(), static_cast<int>(std::max<long long>(wait, 0))) < 0 && errno != EINTR) break;
    if (stopping_.load()) break;
    const auto now = clock::now();
    std::vector<Arriving> still;
    for (std::size_t i = 0; i < arriving.size(); ++i) {
      Arriving& a = arriving[i];
      if ((fds[i + 2].revents & (POLLIN | POLLHUP | POLLERR)) && !read_more(a)) continue;
      if (now >= a.deadline) {
        refuse(a.fd, 408,
               fmt::format("refused: the request did not arrive within {} ms", limits_.request_deadline.count()));
        continue;
      }
      still.push_back(std::move(a));
    }
    arriving.swap(still);
    if (fds[1].revents & POLLIN) accept_all(arriving);
  }
  for (const auto& a : arriving) close_now(a.fd);
  ::close(svr_sock_.exchange(INVALID_SOCKET));  // the streams see the server shutting down
  control_->shutdown();
  general_->shutdown();
  std::unique_lock lock(streams_mu_);
  streams_ended_.wait(lock, [this] { return streams_ == 0; });
}

void GatedServer::accept_all(std::vector<Arriving>& arriving) {
  for (std::size_t i = 0; i < kAcceptsPerLook; ++i) {
    const int fd = ::accept4(svr_sock_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) {
      if ((errno == EMFILE || errno == ENFILE) && !arriving.empty()) {  // make room: the oldest goes
        close_now(arriving.front().fd);
        arriving.erase(arriving.begin());
      }
      return;
    }
    const int one = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    if (arriving.size() >= limits_.arriving_max) {
      close_now(arriving.front().fd);
      arriving.erase(arriving.begin());
    }
    arriving.push_back({fd, {}, clock::now() + limits_.request_deadline});
    if (!read_more(arriving.back())) arriving.pop_back();  // a request sent at once is answered now
  }
}

bool GatedServer::read_more(Arriving& a) {
  const std::size_t most = limits_.head_max + limits_.body_max;
  bool ended = false;
  char buffer[16384];
  while (a.bytes.size() <= most) {
    const ssize_t n = ::recv(a.fd, buffer, sizeof buffer, MSG_DONTWAIT);
    if (n > 0) {
      a.bytes.append(buffer, static_cast<std::size_t>(n));
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    ended = n == 0 || (errno != EAGAIN && errno != EWOULDBLOCK);
    break;
  }
  ArrivedRequest r = read_arrived(a.bytes, limits_.head_max, limits_.body_max);
  switch (r.state) {
    case ArrivedRequest::State::complete:
      a.bytes.resize(r.size);  // anything after it is not answered: one request per connection
      dispatch(a.fd, std::move(a.bytes), r.request);
      return false;
    case ArrivedRequest::State::malformed:
    case ArrivedRequest::State::too_large:
      refuse(a.fd, r.status, r.why);
      return false;
    case ArrivedRequest::State::incomplete:
      if (ended) close_now(a.fd);
      return !ended;
  }
  return false;
}

void GatedServer::dispatch(int fd, std::string bytes, const httplib::Request& request) {
  httplib::Response res;
  if (screen_(request, res) == HandlerResponse::Handled) {
    send_answer(fd, res);
    return;
  }
  answer_on(lane_(request), fd, std::move(bytes));
}

void GatedServer::answer_on(Lane lane, int fd, std::string bytes) {
  const auto answer = [this](int connection, std::string request) {
    if (limits_.refuse_other_users && !peer_allowed(connection))
      return refuse(connection, 403, "refused: this connection is another user's; rtm serve answers only its own user");
    ConnectionStream stream(connection, std::move(request), limits_.write_timeout);
    bool closed = true;
    process_request(stream, true, closed, {});
    close_now(connection);
  };
  if (lane == Lane::stream) {
    bool taken = false;
    {
      std::lock_guard lock(streams_mu_);
      if (streams_ < limits_.stream_threads) ++streams_, taken = true;
    }
    if (!taken)
      return refuse(fd, 503, "refused: as many streams are open as rtm serve runs; close a page or one of its plots");
    std::thread([this, answer, fd, bytes = std::move(bytes)]() mutable {
      answer(fd, std::move(bytes));
      std::lock_guard lock(streams_mu_);
      --streams_;
      streams_ended_.notify_all();
    }).detach();
    return;
  }
  auto& in_lane = lane == Lane::control ? in_control_ : in_general_;
  const std::size_t workers = lane == Lane::control ? limits_.control_workers : limits_.general_workers;
  if (in_lane.load() >= workers + limits_.waiting_max)
    return refuse(fd, 503, fmt::format("refused: {} requests are waiting already; try again", limits_.waiting_max));
  ++in_lane;
  (lane == Lane::control ? control_ : general_)->enqueue([answer, &in_lane, fd, bytes = std::move(bytes)]() mutable {
    answer(fd, std::move(bytes));
    --in_lane;
  });
}

void GatedServer::refuse(int fd, int status, const std::string& why) const {
  httplib::Response res;
  res.status = status;
  res.set_content(nlohmann::json{{"error", why}}.dump(), "application/json");
  send_answer(fd, res);
}

// A short answer written from the accepting thread: what fits into the socket's buffer now
// (all of it, on a connection that has just sent its request), never waiting.
void GatedServer::send_answer(int fd, const httplib::Response& res) const {
  std::string text = fmt::format("HTTP/1.1 {} {}\r\n", res.status, reason(res.status));
  for (const auto& [name, value] : res.headers) text += name + ": " + value + "\r\n";
  for (const auto& [name, value] : headers_)
    if (!res.has_header(name)) text += name + ": " + value + "\r\n";
  text += fmt::format("Content-Length: {}\r\nConnection: close\r\n\r\n", res.body.size()) + res.body;
  [[maybe_unused]] const auto sent = ::send(fd, text.data(), text.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
  close_now(fd);
}

// The kernel's word on who holds the other end: this process's user or root.
bool GatedServer::peer_allowed(int fd) const {
  const auto user = peer_user(fd);
  return user && (*user == 0 || *user == ::geteuid());
}

}  // namespace rtm::cli
