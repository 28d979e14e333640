// SPDX-License-Identifier: Apache-2.0
// rtm serve: the component editor in a browser. An HTTP server (cpp-httplib, Debian's
// libcpp-httplib-dev: a small, well-kept library with SSE support and no framework to adopt)
// serving one page (tools/serve/web/index.html, plain JavaScript, SVG and canvas) and a JSON API that
// runs the same code as the `rtm` commands (Browser, report, values).
//
// The page is three files embedded at build time: GET / (web/index.html), /app.js and
// /style.css; it builds every node from text, never from markup.
//
// API (every /api/ call needs the token: header X-RTM-Token, or ?token= for EventSource):
//   GET  /api/system                       every component as `rtm --json ls -l` shows it, with
//                                          "name_ok": false for a name that breaks the naming
//                                          rule (rtm::check_name): bound by hand, not an RTM
//                                          component; the page shows it marked, with no action;
//                                          a composite with "members": [...] (RTMExt's
//                                          members()) and each member with "member_of"
//   GET  /api/components/<name>            one component as `rtm --json cat` shows it
//   POST /api/components/<name>/<on|off|reset>
//   POST /api/components/<name>/parameters/<parameter>   body {"value": "..."}
//   POST /api/connect, /api/disconnect     body {"from": "a.out0", "to": "b.in0", "type": "once|repeated"}
//   GET  /api/ports/<component>.<port>     the OutPort's latest datum, as `rtm --json get`
//   GET  /api/values?ports=a.out0,b.out1    several at once: {"a.out0": datum or {"error": ...}}
//   GET  /api/system-file?name=N           the running system as a system file `rtm up` takes
//                                          ({"yaml": ..., "left_out": [components it cannot start]})
//   POST /api/system-file                  body: a system file; its connections and activations
//                                          applied to what runs ({"done": [...], "failed": [...]})
//   GET  /api/events?page=P                server-sent events: "system" with /api/system's
//                                          body, when it changes (looked at twice a second,
//                                          once for every page together)
//   GET  /api/recording?file=F              a recording on this machine (rtm record's MCAP):
//                                          {"channels": [{"topic", "type", "count", "elements"}],
//                                          "start_ns", "end_ns", "system": its system file}
//   GET  /api/recording/values?file=F&topic=T
//                                          one channel whole, shaped as a plot's stream sends a
//                                          port's data, at most 5000 data (every k-th), with
//                                          "total" and "shown" (a plot of the recording)
//   GET  /api/values/stream?ports=a.out0,b.out1&page=P
//                                          server-sent events: "values", 25 a second, with
//                                          every datum each port (at most 10) wrote since the
//                                          last, and the counts sent and lost (the page's
//                                          plots; serve/plot_feed.h: the server subscribes
//                                          an InPort of its own to each while it streams)
// Each name in a path is one encoded part (encodeURIComponent). Every call addressed to a
// component by name, in a path or a port address, takes only a name that follows the naming
// rule; any other is refused with 400 and the rule's sentence, and nothing is asked of it.
// Streams: at most 32 open at once, all pages together, each on a thread of its own; a page
// sends an id it made (page=P) and its new stream of a kind replaces its old one; beyond the
// cap a stream is refused with 503 and a sentence.
// A refusal is {"error": "<the same sentence rtm prints>"} with 4xx (503 when full).
//
// Security, because the page can move an arm: loopback by default; the first line on stdout
// is the page's URL with a random token (in the URL's fragment, never sent to a server);
// every API call needs the token; a request from another origin (an Origin header that is
// not this server's) or for another host name (a Host header that is not the address it
// listens on: DNS rebinding) is refused with 403; a non-loopback --listen prints a warning.
// Every answer carries a Content-Security-Policy that lets the page run its own script and
// style files only (no inline script or style, no plugin, frame, form or base, no framing),
// X-Content-Type-Options: nosniff and Referrer-Policy: no-referrer.
// Against another local user (serve_gate.h): on loopback a request from a socket another user
// owns (not root) is refused before anything is answered; a request is screened (token,
// Origin, Host) as soon as it has arrived, before any worker takes it; a request must arrive
// within 2 s; the switches (on, off, reset) have workers of their own, and streams never take
// a worker.
#pragma once

#include "browser/browser.h"

#include <atomic>
#include <functional>
#include <memory>
#include <string>

namespace rtm::cli {

struct ServeOptions {
  std::string host = "127.0.0.1";
  int port = 0;  // 0: any free port
};

// "127.0.0.1:8650", "[::1]:0", ":8650" (loopback) -> ServeOptions; std::invalid_argument otherwise.
ServeOptions parse_listen(const std::string& text);

class WebServer {
 public:
  WebServer(const Browser& browser, ServeOptions options);
  ~WebServer();
  WebServer(const WebServer&) = delete;
  WebServer& operator=(const WebServer&) = delete;

  // Binds (std::runtime_error when it cannot), then serves until interrupted() is true.
  // print_url: called once bound, with the page's URL (token included).
  void run(const std::function<bool()>& interrupted, const std::function<void(const std::string&)>& print_url);

  const std::string& token() const { return token_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::string token_;
};

}  // namespace rtm::cli
