// SPDX-License-Identifier: Apache-2.0
// rtm serve's API, driven over HTTP as its page drives it: the real `rtm serve` against real
// component processes and a real omniNames; every refusal a hostile page or host could meet.
#include "run_command.h"

#include "rtm_test/child_process.h"
#include "rtm_test/omni_names.h"

#include <gtest/gtest.h>
#include <httplib.h>
#include <nlohmann/json.hpp>

#include <signal.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <cctype>
#include <memory>
#include <set>
#include <thread>

namespace {

using nlohmann::json;
using rtm_test::ChildProcess;
using namespace std::chrono_literals;

class RtmServe : public ::testing::Test {
 protected:
  void SetUp() override {
    rtm_test::start_bound(started_, {TALKER_PATH, "--name", "src", "--naming", names_.address(), "--on"});
    rtm_test::start_bound(started_, {TALKER_PATH, "--name", "dst", "--naming", names_.address()});
    serve_ = start_serve({});
  }

  // rtm serve with extra options; reads its URL (the first line) into port_ and token_.
  std::unique_ptr<ChildProcess> start_serve(std::vector<std::string> extra) {
    std::vector<std::string> argv{RTM_CLI_PATH, "--naming", names_.address(), "serve"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    ChildProcess::Options options;
    options.echo_output = false;
    options.extra_env = {"RTM_TLS="};
    auto child = std::make_unique<ChildProcess>(argv, options);
    // http://<host>:<port>/#token=<hex>
    const std::string line = child->wait_for_line("http://");
    const auto slash = line.find("/#token=");
    const auto colon = line.rfind(':', slash);
    EXPECT_TRUE(slash != std::string::npos && colon != std::string::npos) << line;
    if (slash != std::string::npos && colon != std::string::npos) {
      port_ = std::stoi(line.substr(colon + 1, slash - colon - 1));
      token_ = line.substr(slash + 8);
      while (!token_.empty() && std::isspace(static_cast<unsigned char>(token_.back()))) token_.pop_back();
    }
    EXPECT_EQ(token_.size(), 48u) << line;
    return child;
  }

  httplib::Client client() const {
    httplib::Client c("127.0.0.1", port_);
    c.set_read_timeout(10, 0);
    return c;
  }
  httplib::Headers with_token() const { return {{"X-RTM-Token", token_}}; }
  json get_json(const std::string& path) {
    auto r = client().Get(path.c_str(), with_token());
    EXPECT_TRUE(r) << path;
    if (!r) return json();
    EXPECT_EQ(r->status, 200) << r->body;
    return json::parse(r->body);
  }
  httplib::Result post(const std::string& path, const json& body, httplib::Headers headers) {
    return client().Post(path.c_str(), headers, body.dump(), "application/json");
  }
  static json find(const json& list, const std::string& name) {
    for (const auto& c : list)
      if (c["name"] == name) return c;
    return json();
  }
  json subscriptions_of(const std::string& component, const std::string& port) {
    const json described = find(get_json("/api/system"), component);
    for (const auto& p : described["ports"])
      if (p["name"] == port) return p["subscriptions"];
    return json();
  }

  rtm_test::OmniNames names_;
  std::vector<std::unique_ptr<ChildProcess>> started_;
  std::unique_ptr<ChildProcess> serve_;
  int port_ = 0;
  std::string token_;
};

TEST_F(RtmServe, WithoutTheTokenEveryApiCallIsRefusedAndChangesNothing) {
  auto r = client().Get("/api/system");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 401);
  EXPECT_NE(r->body.find("needs the token"), std::string::npos) << r->body;
  r = post("/api/components/src/off", json::object(), {{"X-RTM-Token", std::string(token_.size(), '0')}});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 401);
  EXPECT_EQ(find(get_json("/api/system"), "src")["state"], "on");
}

TEST_F(RtmServe, ACrossOriginRequestIsRefusedEvenWithTheToken) {
  auto headers = with_token();
  headers.emplace("Origin", "http://evil.example");
  const auto r = post("/api/components/src/off", json::object(), headers);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 403);
  EXPECT_NE(r->body.find("cross-origin"), std::string::npos) << r->body;
  EXPECT_EQ(find(get_json("/api/system"), "src")["state"], "on");
  // The page's own origin is accepted.
  headers = with_token();
  headers.emplace("Origin", "http://127.0.0.1:" + std::to_string(port_));
  EXPECT_EQ(client().Get("/api/system", headers)->status, 200);
}

TEST_F(RtmServe, ARequestForAnotherHostNameIsRefusedAgainstDnsRebinding) {
  auto headers = with_token();
  headers.emplace("Host", "evil.example:" + std::to_string(port_));
  const auto r = client().Get("/api/system", headers);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 403);
  EXPECT_NE(r->body.find("not this server's address"), std::string::npos) << r->body;
}

TEST_F(RtmServe, TheSystemListsEachComponentWithItsPortsStateAndTiming) {
  const json system = get_json("/api/system");
  ASSERT_EQ(system.size(), 2u) << system.dump();
  const json src = find(system, "src");
  EXPECT_EQ(src["state"], "on");
  EXPECT_EQ(src["kind"], "talker");
  EXPECT_EQ(src["ports"].size(), 4u);
  EXPECT_TRUE(src.contains("timing"));
  EXPECT_EQ(get_json("/api/components/dst")["name"], "dst");
  const auto missing = client().Get("/api/components/nosuch", with_token());
  EXPECT_EQ(missing->status, 409);
  EXPECT_NE(missing->body.find("nosuch"), std::string::npos) << missing->body;
}

TEST_F(RtmServe, ConnectAndDisconnectWireThePortsAndAMismatchGetsRtmConnectsMessage) {
  auto r = post("/api/connect", {{"from", "src.force"}, {"to", "dst.pos3"}}, with_token());
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 409);
  EXPECT_EQ(json::parse(r->body)["error"], "src.force (RTM::TimedFloat6) -> dst.pos3 (RTM::TimedFloat3): types differ");
  r = post("/api/connect", {{"from", "src.force"}, {"to", "dst.in0"}}, with_token());
  ASSERT_EQ(r->status, 200) << r->body;
  json subs = subscriptions_of("src", "force");
  ASSERT_EQ(subs.size(), 1u);
  EXPECT_EQ(subs[0]["peer"], "dst.in0");
  r = post("/api/disconnect", {{"from", "src.force"}, {"to", "dst.in0"}}, with_token());
  EXPECT_EQ(r->status, 200) << r->body;
  EXPECT_TRUE(subscriptions_of("src", "force").empty());
  r = post("/api/connect", {{"from", "src.force"}}, with_token());
  EXPECT_EQ(r->status, 400) << r->body;
}

TEST_F(RtmServe, OnOffAndResetChangeTheComponentsState) {
  auto r = post("/api/components/src/off", json::object(), with_token());
  ASSERT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(find(get_json("/api/system"), "src")["state"], "off");
  r = post("/api/components/src/on", json::object(), with_token());
  ASSERT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(find(get_json("/api/system"), "src")["state"], "on");
  r = post("/api/components/nosuch/on", json::object(), with_token());
  EXPECT_EQ(r->status, 409);
}

TEST_F(RtmServe, APortsLatestDatumComesAsRtmGetShowsIt) {
  json datum;
  for (int i = 0; i < 50; ++i) {
    auto r = client().Get("/api/ports/src.force", with_token());
    if (r && r->status == 200) {
      datum = json::parse(r->body);
      break;
    }
    std::this_thread::sleep_for(20ms);
  }
  EXPECT_EQ(datum["type"], "RTM::TimedFloat6") << datum.dump();
  EXPECT_EQ(datum["values"].size(), 6u);
  const auto in = client().Get("/api/ports/dst.in0", with_token());
  EXPECT_EQ(in->status, 409);
  EXPECT_NE(in->body.find("is an InPort"), std::string::npos) << in->body;
}

TEST_F(RtmServe, TheEventStreamSendsTheSystemAndAComponentThatBindsLater) {
  std::string received;
  bool saw_late = false;
  std::thread late([&] {
    std::this_thread::sleep_for(300ms);
    rtm_test::start_bound(started_, {TALKER_PATH, "--name", "late", "--naming", names_.address()});
  });
  httplib::Client c = client();
  c.Get(("/api/events?token=" + token_).c_str(), [&](const char* data, std::size_t size) {
    received.append(data, size);
    saw_late = received.find("\"name\":\"late\"") != std::string::npos;
    return !saw_late && received.size() < 4'000'000;
  });
  late.join();
  EXPECT_EQ(received.rfind("event: system\ndata: [", 0), 0u) << received.substr(0, 200);
  EXPECT_TRUE(saw_late) << "no event named the component that bound later";
}

// Each open page's event stream holds one of the server's workers for as long as it is open
// (httplib's default pool has 8). Twenty-four pages open at once: each gets the system, and the
// plots' poll is still answered beside them.
TEST_F(RtmServe, TwentyFourPagesOpenAtOnceEachGetTheSystemAndThePlotsStillAnswer) {
  constexpr int kPages = 24;
  std::atomic<int> fed{0};
  std::atomic<bool> close{false};
  std::vector<std::thread> pages;
  for (int page = 0; page < kPages; ++page)
    pages.emplace_back([&] {
      std::string received;
      bool counted = false;
      httplib::Client c = client();
      c.Get(("/api/events?token=" + token_).c_str(), [&](const char* data, std::size_t size) {
        received.append(data, size);
        if (!counted && received.rfind("event: system\ndata: [", 0) == 0) counted = true, ++fed;
        return !close.load();  // open until the test ends; a keep-alive comes every second
      });
    });
  for (int i = 0; i < 600 && fed.load() < kPages; ++i) std::this_thread::sleep_for(50ms);
  const int fed_pages = fed.load();
  auto r = client().Get("/api/values?ports=src.force", with_token());
  close = true;
  for (auto& t : pages) t.join();
  EXPECT_EQ(fed_pages, kPages) << "pages left waiting for a worker";
  ASSERT_TRUE(r) << "the plots' poll was not answered: " << httplib::to_string(r.error());
  EXPECT_EQ(r->status, 200) << r->body;
}

// The plots' stream: each event holds every port asked for, a port that is none with its
// reason (the others still plotted), and the stamps of the live port move on.
TEST_F(RtmServe, ThePlotsStreamSendsEveryPortInEachEventAndAPortThatIsNoneWithItsReason) {
  std::string received;
  std::vector<json> events;
  httplib::Client c = client();
  c.Get(("/api/values/stream?ports=src.force,dst.nothing&token=" + token_).c_str(),
        [&](const char* data, std::size_t size) {
          received.append(data, size);
          for (std::size_t end; (end = received.find("\n\n")) != std::string::npos;) {
            const std::string event = received.substr(0, end);
            received.erase(0, end + 2);
            const auto at = event.find("data: ");
            if (event.rfind("event: values\n", 0) == 0 && at != std::string::npos)
              events.push_back(json::parse(event.substr(at + 6)));
          }
          return events.size() < 10;
        });
  ASSERT_EQ(events.size(), 10u) << received.substr(0, 300);
  std::set<std::string> stamps;
  for (const json& e : events) {
    ASSERT_EQ(e.size(), 2u) << e.dump();
    EXPECT_NE(e["dst.nothing"].value("error", "").find("nothing"), std::string::npos) << e.dump();
    if (e["src.force"].contains("time")) stamps.insert(e["src.force"]["time"].dump());
  }
  EXPECT_EQ(events.back()["src.force"]["type"], "RTM::TimedFloat6") << events.back().dump();
  EXPECT_GE(stamps.size(), 5u) << "the live port's data did not move on between events";
}

TEST_F(RtmServe, ALoadedSystemFileIsShownWithWhatApplyingWouldDoAndChangesNothingUntilApplied) {
  const std::string yaml = R"(name: shown
components:
  - {name: src, command: [rtm-test-talker]}
  - {name: dst, command: [rtm-test-talker]}
  - {name: third, command: [rtm-test-talker]}
connections:
  - {from: src.force, to: dst.in0}
  - {from: src.out0, to: dst.pos3}
activate: [dst]
)";
  const auto shown = client().Post("/api/system-file/preview", with_token(), yaml, "text/yaml");
  ASSERT_EQ(shown->status, 200) << shown->body;
  const json r = json::parse(shown->body);
  EXPECT_EQ(r["name"], "shown");
  ASSERT_EQ(r["connections"].size(), 2u) << r.dump();
  EXPECT_EQ(r["connections"][0]["status"], "to connect") << r.dump();
  EXPECT_EQ(r["connections"][1]["from"], "src.out0");
  EXPECT_EQ(r["connections"][1]["status"], "error");
  EXPECT_EQ(r["connections"][1]["error"], "src.out0 (RTM::TimedFloat6) -> dst.pos3 (RTM::TimedFloat3): types differ")
      << "the message of rtm connect";
  EXPECT_EQ(r["activate"][0]["name"], "dst");
  EXPECT_EQ(r["activate"][0]["now"], "off");
  EXPECT_EQ(r["not_running"], json::array({"third"}));
  EXPECT_TRUE(subscriptions_of("src", "force").empty()) << "showing a file connected something";
  EXPECT_EQ(get_json("/api/components/dst")["state"], "off") << "showing a file turned something on";
  // Once connected, the same file shows the connection as made, by the port's own name.
  ASSERT_EQ(post("/api/connect", {{"from", "src.force"}, {"to", "dst.in0"}}, with_token())->status, 200);
  const json again = json::parse(client().Post("/api/system-file/preview", with_token(), yaml, "text/yaml")->body);
  EXPECT_EQ(again["connections"][0]["status"], "connected") << again.dump();
  // A malformed file is refused with the parser's sentence, as apply refuses it.
  const auto bad = client().Post("/api/system-file/preview", with_token(), "components: 5", "text/yaml");
  EXPECT_EQ(bad->status, 400);
  EXPECT_NE(bad->body.find("'components' must be a non-empty list"), std::string::npos) << bad->body;
}

TEST_F(RtmServe, SaveWritesASystemFileRtmUpAcceptsAndApplyingItRestoresTheWiring) {
  ASSERT_EQ(post("/api/connect", {{"from", "src.force"}, {"to", "dst.in0"}}, with_token())->status, 200);
  const json saved = get_json("/api/system-file?name=pair");
  const std::string yaml = saved["yaml"];
  EXPECT_TRUE(saved["left_out"].empty()) << saved.dump();
  EXPECT_NE(yaml.find("{from: src.force, to: dst.in0}"), std::string::npos) << yaml;
  EXPECT_NE(yaml.find("rtm-test-talker"), std::string::npos) << yaml;
  EXPECT_EQ(yaml.find("--naming"), std::string::npos) << "rtm up adds --naming itself: " << yaml;
  // Unwire, then apply the saved file: the wiring comes back.
  ASSERT_EQ(post("/api/disconnect", {{"from", "src.force"}, {"to", "dst.in0"}}, with_token())->status, 200);
  const auto applied = client().Post("/api/system-file", with_token(), yaml, "text/yaml");
  ASSERT_EQ(applied->status, 200) << applied->body;
  EXPECT_TRUE(json::parse(applied->body)["failed"].empty()) << applied->body;
  EXPECT_EQ(subscriptions_of("src", "force").size(), 1u);
  // A malformed file is refused with the parser's sentence.
  const auto bad = client().Post("/api/system-file", with_token(), "components: 5", "text/yaml");
  EXPECT_EQ(bad->status, 400);
  EXPECT_NE(bad->body.find("'components' must be a non-empty list"), std::string::npos) << bad->body;
  // rtm up takes the saved file: it starts its own copies under the same names in a second
  // naming service and wires them as saved.
  rtm_test::OmniNames other;
  const auto dir = std::filesystem::temp_directory_path() / ("rtm-serve-saved-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "pair.yaml") << yaml;
  auto up = rtm_test::run_command({RTM_CLI_PATH, "--naming", other.address(), "up", (dir / "pair.yaml").string()},
                                  {"XDG_RUNTIME_DIR=" + dir.string(), "RTM_TLS="}, 30s);
  EXPECT_EQ(up.exit_code, 0) << up.out << up.err;
  auto cat = rtm_test::run_command({RTM_CLI_PATH, "--naming", other.address(), "cat", "src"});
  EXPECT_NE(cat.out.find("-> dst.in0 (repeated)"), std::string::npos) << cat.out;
  rtm_test::run_command({RTM_CLI_PATH, "--naming", other.address(), "down", "pair"},
                        {"XDG_RUNTIME_DIR=" + dir.string(), "RTM_TLS="}, 30s);
  std::filesystem::remove_all(dir);
}

TEST_F(RtmServe, ThePageIsServedSelfContainedAndStopsOnCtrlC) {
  const auto page = client().Get("/");
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
  EXPECT_NE(page->body.find("<svg"), std::string::npos);
  EXPECT_EQ(page->body.find("<script src"), std::string::npos) << "the page loads a script from elsewhere";
  EXPECT_NE(page->get_header_value("Content-Security-Policy").find("default-src 'self'"), std::string::npos);
  serve_->send_signal(SIGINT);
  const auto status = serve_->wait_for_exit(5s);
  ASSERT_TRUE(status) << "rtm serve did not stop on SIGINT";
  EXPECT_TRUE(status->clean()) << status->to_string();
}

TEST_F(RtmServe, ANonLoopbackListenWarnsAndABadOneIsAUsageError) {
  auto open = start_serve({"--listen", "0.0.0.0:0"});
  EXPECT_NE(open->output().find("not loopback"), std::string::npos) << open->output();
  const auto bad = rtm_test::run_command({RTM_CLI_PATH, "--naming", names_.address(), "serve", "--listen", "nowhere"});
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("expected HOST:PORT"), std::string::npos) << bad.err;
}

}  // namespace
