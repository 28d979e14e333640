// SPDX-License-Identifier: Apache-2.0
#include "watch.h"

#include "report.h"
#include "browser/values.h"
#include "browser/watch_port.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <stdexcept>

namespace rtm::cli {

namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

// A header field as RFC 4180 has it: quoted, quotes doubled, when it holds a comma, a quote or
// a line break (an element name is the component's text, not ours).
std::string csv_field(const std::string& text) {
  if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
  std::string quoted = "\"";
  for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

// Where the data go: CSV, JSON lines, text lines or the refreshing live line.
class WatchDisplay {
 public:
  WatchDisplay(const ResolvedPort& port, const WatchOptions& options)
      : port_(port), options_(options), units_(port.units()), names_(port.names()),
        live_(!options.json && ::isatty(STDOUT_FILENO) && options.count <= 0) {
    if (options.csv_path.empty()) return;
    csv_.open(options.csv_path);
    if (!csv_) throw std::runtime_error(fmt::format("cannot write {}", options.csv_path));
    csv_ << "time_ns";
  }
  bool live() const { return live_; }

  // Shows one datum; returns its own time stamp (ns).
  long long show(const CORBA::Any& any) {
    const Sample sample = to_sample(any);
    if (csv_.is_open()) write_csv(any, sample);
    if (options_.json) {
      fmt::print("{}\n", format_json(any).dump());
    } else if (!live_) {
      fmt::print("{}\n", terminal_text(format_text(any, units_, names_)));
    } else {
      latest_ = terminal_text(format_text(any, units_, names_));
    }
    return sample.time_ns;
  }
  // What was shown reaches the CSV file now: a reader (a plot, `tail -f`) sees it as it comes.
  void flush() {
    if (csv_.is_open()) csv_.flush();
  }

  void refresh(std::uint64_t shown, double rate, unsigned long long dropped_publisher, std::uint64_t dropped_display) {
    fmt::print("\r\x1b[2K{}  {}\n\x1b[2K  received {}  rate {:.1f} Hz  dropped {} (publisher) + {} (display)\x1b[1A",
               port_.address, latest_.empty() ? "(waiting for data)" : latest_, shown, rate, dropped_publisher,
               dropped_display);
    std::fflush(stdout);
  }

 private:
  void write_csv(const CORBA::Any& any, const Sample& s) {
    if (!csv_header_done_) {
      // Labelled as `rtm get` labels them: the port's element names, else leaf paths ("p.x"), else v0, v1, ...
      for (const auto& label : value_labels(any, names_)) csv_ << ',' << csv_field(label);
      csv_ << "\n";
      csv_header_done_ = true;
    }
    csv_ << s.time_ns;
    for (double v : s.values) csv_ << "," << v;
    csv_ << "\n";
  }

  const ResolvedPort& port_;
  const WatchOptions& options_;
  const std::vector<std::string> units_;
  const std::vector<std::string> names_;
  const bool live_;
  std::ofstream csv_;
  bool csv_header_done_ = false;
  std::string latest_;
};

// The rate of the data shown, by their own stamps: intervals over the time they span (0 when
// fewer than two, or stamps that do not advance). Not the watch's own wall time, which holds
// the wait for the first datum.
struct StampSpan {
  long long first_ns = 0, last_ns = 0;
  std::uint64_t count = 0;
  void add(long long stamp_ns) {
    if (count++ == 0) first_ns = stamp_ns;
    last_ns = stamp_ns;
  }
  double rate_hz() const {
    if (count < 2 || last_ns <= first_ns) return 0.0;
    return static_cast<double>(count - 1) * 1e9 / static_cast<double>(last_ns - first_ns);
  }
};

// path: how the data came, "shared memory" (the publisher's ring) or "CORBA" (a put each).
void print_summary(const ResolvedPort& port, const WatchSubscription& sub, std::uint64_t shown, double elapsed,
                   double rate_hz, unsigned long long dropped_publisher, const char* path, bool as_json) {
  if (as_json) {
    fmt::print("{}\n", json{{"summary",
                             {{"port", port.address},
                              {"path", path},
                              {"received", shown},
                              {"seconds", elapsed},
                              {"rate_hz", rate_hz},
                              {"dropped_publisher", dropped_publisher},
                              {"dropped_display", sub.port().overflowed()},
                              {"shared_memory", sub.port().shared_memory()},
                              {"dropped_late", sub.port().late()},
                              {"rejected", sub.port().rejected()}}}}
                           .dump());
    return;
  }
  fmt::print(stderr,
             "{}: received {} in {:.2f} s ({:.1f} Hz by their stamps, through {}), dropped {} by the publisher, {} by "
             "the display, {} late (after a later one), {} of a wrong type\n",
             port.address, shown, elapsed, rate_hz, path, dropped_publisher,
             sub.port().overflowed(), sub.port().late(), sub.port().rejected());
}

}  // namespace

int watch(const Browser& browser, rtm::Orb& orb, const std::string& address, const WatchOptions& options,
          const std::atomic<bool>& interrupted) {
  const ResolvedPort port = browser.port(PortAddress::parse(address));
  if (port.direction != Direction::out) throw BrowseError(fmt::format("{} is an InPort; watch an OutPort", port.address));
  WatchDisplay display(port, options);
  WatchSubscription sub(orb, port.object, port.type, port.address, fmt::format("rtm-watch-{}", ::getpid()), 4096,
                        "the watch subscription");
  const auto start = Clock::now();
  const auto refresh = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(1.0 / std::max(options.rate_hz, 0.1)));
  auto next_refresh = start, window_start = start;
  std::vector<CORBA::Any> batch;
  std::uint64_t shown = 0, window_count = 0;
  StampSpan stamps;
  double rate = 0;
  const auto done = [&] { return options.count > 0 && static_cast<long>(shown) >= options.count; };
  while (!interrupted.load() && !done()) {
    batch.clear();
    sub.port().drain(batch, std::chrono::milliseconds(50));
    for (std::size_t i = 0; i < batch.size() && !done(); ++i, ++shown, ++window_count) stamps.add(display.show(batch[i]));
    if (!batch.empty()) display.flush();
    const auto now = Clock::now();
    if (now - window_start >= std::chrono::seconds(1)) {
      rate = window_count / std::chrono::duration<double>(now - window_start).count();
      window_start = now;
      window_count = 0;
    }
    if (display.live() && now >= next_refresh) {
      next_refresh = now + refresh;
      display.refresh(shown, rate, sub.publisher_dropped().value_or(0), sub.port().overflowed());
    }
    if (options.duration_s > 0 && now - start >= std::chrono::duration<double>(options.duration_s)) break;
  }
  const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  const unsigned long long dropped_publisher = sub.publisher_dropped().value_or(0);
  const char* path = sub.port().reads_ring() ? "shared memory" : "CORBA";
  const std::string unsubscribe_failed = sub.finish();
  if (!unsubscribe_failed.empty())
    fmt::print(stderr, "rtm watch: unsubscribe from {} failed: {}\n", port.address, unsubscribe_failed);
  if (display.live()) fmt::print("\n\n");
  print_summary(port, sub, shown, elapsed, stamps.rate_hz(), dropped_publisher, path, options.json);
  return unsubscribe_failed.empty() ? 0 : 1;
}

}  // namespace rtm::cli
