// SPDX-License-Identifier: Apache-2.0
// rtm serve's connections, from accept to the thread that answers them.
//
// httplib's own accept loop gives every connection a worker from its first byte: forty open
// event streams, or forty requests sent by halves, left the API waiting for a free worker (an
// `off` waited 19.9 s, and 7.1 s per round of half-sent requests). GatedServer keeps httplib's
// routing, handlers and responses, and replaces what comes before them:
//   - one thread accepts and holds each connection whose request has not fully arrived
//     (non-blocking, polled), with a deadline and a size cap, and no worker;
//   - a request that has fully arrived is screened there by the server's own screen: one
//     without the token is refused at once, never reaching a worker;
//   - what passes runs on one of three lanes: the switches (on, off, reset) on workers of their
//     own, the rest on the general workers, the event streams each on a thread of its own (at
//     most Limits::stream_threads); a lane that is full refuses with 503 and a sentence;
//   - on loopback, a connection whose socket another local user owns is refused before anything
//     is answered (the kernel's word, peer_user(); asked on the lane, after the screen, so that
//     what another user sends without the token costs no look-up).
// Each connection carries one request (the answer says Connection: close).
#pragma once

#include <httplib.h>
#include <sys/types.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace rtm::cli {

// A request's bytes as they have arrived so far, read as far as the gate needs.
struct ArrivedRequest {
  enum class State {
    incomplete,  // head or body still arriving
    complete,    // request holds the head; size is head and body, bytes
    malformed,   // why says what is wrong (answered 400)
    too_large,   // a head over head_max or a body over body_max (answered 431 / 413)
  };
  State state = State::incomplete;
  httplib::Request request;  // method, target, version, path (decoded), params, headers
  std::size_t size = 0;
  int status = 0;   // the refusal's status, when malformed or too large
  std::string why;  // the refusal's sentence
};
// Reads a request head (request line and headers, up to the empty line) and whether its
// Content-Length body has arrived, as httplib would read it: the path decoded, the query
// parsed. A body must come with Content-Length (no chunked request bodies).
ArrivedRequest read_arrived(std::string_view bytes, std::size_t head_max, std::size_t body_max);

// The user of the process at the other end of a TCP connection of this host (of this network
// namespace), as the kernel says (rtm::socket_peer: the one socket asked of its socket
// diagnostics, whatever the number of sockets on the host). nullopt for a peer on another host
// or an unconnected socket.
std::optional<uid_t> peer_user(int fd);

class GatedServer : public httplib::Server {
 public:
  enum class Lane { control, general, stream };

  struct Limits {
    std::chrono::milliseconds request_deadline{2000};  // from accept to the whole request
    std::size_t head_max = 16 * 1024;                  // bytes
    std::size_t body_max = 1024 * 1024;                // bytes
    std::size_t arriving_max = 256;   // connections still arriving; beyond, the oldest is closed
    std::size_t control_workers = 2;  // on, off, reset
    std::size_t general_workers = 6;  // the page and the rest of the API
    std::size_t waiting_max = 64;     // requests queued per lane beyond its workers
    std::size_t stream_threads = 64;  // streams running (the server caps its own slots lower)
    std::chrono::milliseconds write_timeout{2000};  // a reader that stops reading is dropped
    bool refuse_other_users = false;  // on loopback: answer only this process's user and root
  };

  // screen: the server's security screen (Handled: refused, with the answer in res); lane:
  // where a screened request runs; headers: sent with every answer, the gate's refusals too.
  GatedServer(HandlerWithResponse screen, std::function<Lane(const httplib::Request&)> lane,
              httplib::Headers headers, Limits limits);
  ~GatedServer() override;
  GatedServer(const GatedServer&) = delete;
  GatedServer& operator=(const GatedServer&) = delete;

  // After bind_to_port or bind_to_any_port: accepts and dispatches until stop_serving().
  void serve();
  // Ends serve() and the streams (they see the server shutting down), then waits for every
  // request in hand to end. From another thread than serve()'s.
  void stop_serving();

 private:
  struct Arriving;
  void accept_all(std::vector<Arriving>& arriving);
  // false: the connection is done with (closed or handed on).
  bool read_more(Arriving& a);
  void dispatch(int fd, std::string bytes, const httplib::Request& request);
  void answer_on(Lane lane, int fd, std::string bytes);
  void refuse(int fd, int status, const std::string& why) const;
  void send_answer(int fd, const httplib::Response& res) const;
  bool peer_allowed(int fd) const;

  HandlerWithResponse screen_;
  std::function<Lane(const httplib::Request&)> lane_;
  httplib::Headers headers_;
  Limits limits_;
  int wake_fd_ = -1;  // eventfd: stop_serving() wakes the accept loop
  std::atomic<bool> stopping_{false};
  std::unique_ptr<httplib::ThreadPool> control_, general_;
  std::atomic<std::size_t> in_control_{0}, in_general_{0};  // queued or running
  std::mutex streams_mu_;
  std::condition_variable streams_ended_;
  std::size_t streams_ = 0;  // stream threads running
};

}  // namespace rtm::cli
