// SPDX-License-Identifier: Apache-2.0
// Two processes over loopback: one-way latency of TimedFloat6 paced at 1 kHz and burst
// throughput, through RTM's ports (OutPort::write in the publisher process -> put/push ->
// InPort in this process), beside a bare omniORB put(any) on a servant with no RTM code as
// the floor, in the same run. Each transport is chosen by the publisher's client transport
// rule: the receiving InPort offers both TCP and a unix socket.
//
//   rtm_bench_twoproc [--cpu N] [--paced N] [--burst N] [--transport tcp|unix|ssl|shm|both|all]
//                     [--neighbour none|busy|both] [--access-cost 1]
//
// --transport takes one name, a comma list (tcp,unix,shm), both (tcp and unix) or all. shm is
// the same-host path: the OutPort hands a FIFO InPort of this process its shared-memory ring
// (rtm/outport.h), and a thread here reads the port back to back (a reader polling in its own
// cycle, without the cycle); its floor is the bare ring (rt/shm_ring.h) between the same two
// processes, read by the same thread with nothing of the ports in between.
//
// --access-cost 1: instead, what access control's check costs a put (host/access.h): the bare
// put with the receiver owner-only and open to all, alternating.
//
// both: tcp and unix; all: those and ssl (giop:ssl: with client certificates, host/tls.h,
// from a throwaway authority this run makes).
//
// One-way latency is measured in this process, from the stamp the publisher puts in the datum
// just before write() (or the bare put) to the receiving upcall: RTM's and the bare rows
// measure the same span, and both publishers pace on the same PeriodicActivity. The RTM paced
// rows run once per delivery policy (write() calls itself when idle; always the delivery
// thread) and report what write() cost the publisher's periodic thread; a second bare row
// sets the 2 ms call timeout write() puts on its calls (what a bounded call costs omniORB).
// The paced rows run in ten alternating slices, the twoway bursts (RTM and bare) in four, so
// that the rows compared see the same machine; rates are counted at the receiver for both.
// --neighbour busy starts a process that keeps one CPU busy (a spinning loop
// at normal priority) for the rows, as another program on the machine would; both = each row
// quiet, then busy. --cpu N pins both processes to CPU N (MACHINE-NOTES: stages that wake each
// other are fastest on one CPU). This process is the receiver; it runs itself again as the
// publisher (--role publisher ...), one child per row or slice.
#include "busy_neighbour.h"
#include "bench_stats.h"

#include "rt/activity.h"
#include "host/access.h"
#include "rtm/inport.h"
#include "rtm/log.h"
#include "rtm/orb.h"
#include "rtm/outport.h"
#include "rtm/ring_types.h"
#include "rt/shm_ring.h"
#include "rt/shm_segment.h"
#include "host/tls.h"

#include <fcntl.h>
#include <signal.h>
#include <sched.h>
#include <sys/resource.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <memory>
#include <map>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <utility>

extern char** environ;

namespace {

using Float6In = rtm::InPort<RTM::TimedFloat6>;
using Float6Out = rtm::OutPort<RTM::TimedFloat6>;

struct Args {
  std::map<std::string, std::string> values;
  std::string get(const std::string& key, const std::string& fallback) const {
    auto it = values.find(key);
    return it == values.end() ? fallback : it->second;
  }
  long number(const std::string& key, long fallback) const { return std::stol(get(key, std::to_string(fallback))); }
};

Args parse(int argc, char** argv) {
  Args args;
  for (int i = 1; i + 1 < argc; i += 2) args.values[argv[i]] = argv[i + 1];
  return args;
}

void pin(int cpu) {
  if (cpu < 0) return;
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  sched_setaffinity(0, sizeof(set), &set);
}

void stamp(RTM::TimedFloat6& d) {
  const auto now = rtm_bench::monotonic_ns();
  d.tm.sec = static_cast<CORBA::ULong>(now / 1'000'000'000);
  d.tm.nsec = static_cast<CORBA::ULong>(now % 1'000'000'000);
}

std::int64_t stamp_ns(const RTM::TimedFloat6& d) { return std::int64_t{d.tm.sec} * 1'000'000'000 + d.tm.nsec; }

// ---------------------------------------------------------------------------------------------
// Publisher (child process)
// ---------------------------------------------------------------------------------------------

// The bare modes: put() on the target's InPort with no OutPort in between, paced at 1 kHz on
// the same periodic thread as the RTM rows (so that pacing and thread set-up are the same
// work on both sides), or back to back; each datum stamped just before its put (the receiver
// measures one-way); prints the round trips. timeout_ms > 0: with that omniORB call timeout.
int run_bare_publisher(RTM::InPort_ptr target, const std::string& mode, std::size_t count, int cpu,
                       CORBA::ULong timeout_ms) {
  CORBA::Any any;
  RTM::TimedFloat6 datum{};
  any <<= datum;
  for (int i = 0; i < 1000; ++i) target->put(any);  // connect and warm up (not counted: stamp 0)
  // The bound RTM's write() puts on its calls, for the row that shows what the bound costs.
  if (timeout_ms > 0) omniORB::setClientCallTimeout(target, timeout_ms);
  std::vector<std::int64_t> rtt_ns;
  rtt_ns.reserve(count);
  std::uint64_t timed_out = 0;
  const auto one = [&] {
    stamp(datum);
    any <<= datum;
    const auto before = rtm_bench::monotonic_ns();
    try {
      target->put(any);
    } catch (const CORBA::TIMEOUT&) {
      ++timed_out;  // the bounded row: a host stall outlived the bound; counted, not fatal
    }
    rtt_ns.push_back(rtm_bench::monotonic_ns() - before);
  };
  const auto start = rtm_bench::monotonic_ns();
  if (mode == "bare-paced") {
    rtm::PeriodicOptions periodic;
    periodic.period_ns = 1'000'000;
    periodic.cpu = cpu;
    std::atomic<bool> done{false};
    rtm::PeriodicActivity activity(
        [&](const rtm::CycleContext&) {
          one();
          const bool more = rtt_ns.size() < count;
          if (!more) done.store(true);
          return more;
        },
        periodic);
    activity.start();
    while (!done.load()) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    activity.stop();
  } else {
    for (std::size_t i = 0; i < count; ++i) one();
  }
  const auto elapsed_ns = rtm_bench::monotonic_ns() - start;
  const auto s = rtm_bench::summarize(rtt_ns);
  std::printf("RESULT rtt_p50_us=%.2f rtt_p99_us=%.2f rtt_max_us=%.2f rate_per_s=%.0f timed_out=%llu\n", s.p50_us,
              s.p99_us, s.max_us, static_cast<double>(count) / (static_cast<double>(elapsed_ns) / 1e9),
              static_cast<unsigned long long>(timed_out));
  return 0;
}

// Writes `count` data (paced, back to back) or for a second (flood) through the OutPort.
void write_through_port(Float6Out& out, const std::string& mode, std::size_t count, int cpu) {
  RTM::TimedFloat6 datum{};
  if (mode == "paced") {
    std::atomic<std::size_t> written{0};
    rtm::PeriodicOptions periodic;
    periodic.period_ns = 1'000'000;
    periodic.cpu = cpu;
    rtm::PeriodicActivity activity(
        [&](const rtm::CycleContext&) {
          stamp(datum);
          out.write(datum);
          return written.fetch_add(1) + 1 < count;
        },
        periodic);
    activity.start();
    while (written.load() < count) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    activity.stop();
  } else if (mode == "stream-oneway") {
    // A pipelined stream: each write as soon as the previous one returned, never waiting for
    // the subscriber; the receiver counts what it got.
    for (std::size_t i = 0; i < count; ++i) {
      stamp(datum);
      out.write(datum);
    }
  } else if (mode == "flood") {
    // A writer that never waits, for one second (yielding between writes so that a delivery
    // thread on the same CPU runs): the subscriber gets what the delivery thread manages,
    // the rest is overwritten in the slot (counted as dropped).
    const auto end = rtm_bench::monotonic_ns() + 1'000'000'000;
    while (rtm_bench::monotonic_ns() < end) {
      stamp(datum);
      out.write(datum);
      sched_yield();
    }
  } else {
    // Back to back, each write once the previous datum was delivered (or its delivery failed:
    // a call that timed out is counted, not retried): the rate at which the port path can
    // carry every datum (a slot overwritten unread would be a lost message).
    for (std::size_t i = 0; i < count; ++i) {
      stamp(datum);
      out.write(datum);
      for (;;) {
        const rtm::OutPortCounters c = out.counters_snapshot();
        if (c.pushed + c.failed + c.dropped > i) break;
        sched_yield();
      }
    }
  }
}

// The floor of the shm rows: the bare ring, made here and handed to the receiver's
// BareRingPort by one attach_ring call (the port's own negotiation, nothing of it per datum),
// written paced at 1 kHz on the same periodic thread as the RTM rows, or back to back.
int run_ring_publisher(RTM::InPort_ptr target, const std::string& mode, std::size_t count, int cpu) {
  RTM::InPortShm_var reader = RTM::InPortShm::_narrow(target);
  if (CORBA::is_nil(reader)) {
    std::fprintf(stderr, "publisher: the target reads no ring\n");
    return 1;
  }
  const rtm::ShmRingShape shape{rtm::kMinRingSlots, sizeof(RTM::TimedFloat6), rtm::ring_type_id<RTM::TimedFloat6>()};
  rtm::ShmSegment segment = rtm::ShmSegment::create(rtm::shm_ring_bytes(shape), "bench");
  rtm::ShmRingWriter writer(segment.data(), segment.size(), shape);
  CORBA::String_var why;
  if (!reader->attach_ring(segment.name().c_str(), rtm::shm_host_identity().c_str(), shape.type_id, ::getpid(),
                           rtm::process_start_ticks(::getpid()), why.out())) {
    std::fprintf(stderr, "publisher: attach_ring refused: %s\n", why.in());
    return 1;
  }
  RTM::TimedFloat6 datum{};
  const auto one = [&] {
    stamp(datum);
    writer.write(std::as_bytes(std::span(&datum, 1)));
  };
  const auto writing_from = rtm_bench::monotonic_ns();
  if (mode == "ring-paced") {
    rtm::PeriodicOptions periodic;
    periodic.period_ns = 1'000'000;
    periodic.cpu = cpu;
    std::atomic<std::size_t> written{0};
    rtm::PeriodicActivity activity(
        [&](const rtm::CycleContext&) {
          one();
          return written.fetch_add(1) + 1 < count;
        },
        periodic);
    activity.start();
    while (written.load() < count) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    activity.stop();
  } else {
    for (std::size_t i = 0; i < count; ++i) one();
  }
  const double writing_s = static_cast<double>(rtm_bench::monotonic_ns() - writing_from) / 1e9;
  std::this_thread::sleep_for(std::chrono::milliseconds(100));  // the reader takes the last ones
  reader->detach_ring(segment.name().c_str());
  std::printf("RESULT written=%llu (%.0f/s)\n", static_cast<unsigned long long>(writer.written()),
              static_cast<double>(writer.written()) / writing_s);
  return 0;
}

int run_publisher(const Args& args) {
  const int cpu = static_cast<int>(args.number("--cpu", -1));
  pin(cpu);
  const std::string transport = args.get("--transport", "tcp");
  const std::string client_transport = transport == "shm" ? "unix" : transport;  // shm: attach_ring's call
  const std::string mode = args.get("--mode", "paced");
  const auto count = static_cast<std::size_t>(args.number("--count", 1000));
  if (transport == "ssl") rtm::configure_tls(rtm::check_tls_folder(args.get("--tls", "")));
  rtm::Orb orb({"-ORBendPoint", "giop:tcp:127.0.0.1:", "-ORBclientTransportRule", "* " + client_transport});
  CORBA::Object_var target_object = orb.from_string(args.get("--target", ""));
  RTM::InPort_var target = RTM::InPort::_narrow(target_object);
  if (mode == "bare-paced" || mode == "bare-burst")
    return run_bare_publisher(target, mode, count, cpu, static_cast<CORBA::ULong>(args.number("--bare-timeout-ms", 0)));
  if (mode == "ring-paced" || mode == "ring-stream") return run_ring_publisher(target, mode, count, cpu);

  rtm::OutPortOptions options;
  options.oneway = mode == "stream-oneway";
  options.shared_memory = args.get("--transport", "tcp") == "shm";
  options.writer_call_timeout_ms = static_cast<std::uint32_t>(args.number("--writer-timeout-ms", 2));
  // "writer-unbounded" is writer_when_idle with --writer-timeout-ms 0 (set by the receiver).
  if (args.get("--delivery", "writer") == "thread") options.delivery = rtm::OutPortOptions::Delivery::thread;
  rtm::log().set_level(spdlog::level::warn);
  PortableServer::Servant_var<Float6Out> out(new Float6Out("out", "publisher", options));
  RTM::OutPortEx_var out_ref = out->activate(orb);
  if (!out->subscribe(RTM::repeated, target)) {
    std::fprintf(stderr, "publisher: subscribe refused: %s\n", out->last_error_text().c_str());
    return 1;
  }
  const auto writing_from = rtm_bench::monotonic_ns();
  write_through_port(*out, mode, count, cpu);
  const double writing_s = static_cast<double>(rtm_bench::monotonic_ns() - writing_from) / 1e9;
  // Let the delivery thread finish what is in flight.
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const auto c = out->counters_snapshot();
  const rtm::WriteCost w = out->write_cost();
  std::printf("RESULT written=%llu (%.0f/s) pushed=%llu (by write() %llu) dropped=%llu failed=%llu (timed out %llu); write() p50 %.1f p99 %.1f max %.1f us\n",
              static_cast<unsigned long long>(c.written), static_cast<double>(c.written) / writing_s, static_cast<unsigned long long>(c.pushed),
              static_cast<unsigned long long>(c.by_writer), static_cast<unsigned long long>(c.dropped),
              static_cast<unsigned long long>(c.failed), static_cast<unsigned long long>(c.timed_out),
              static_cast<double>(w.p50_ns) / 1e3, static_cast<double>(w.p99_ns) / 1e3,
              static_cast<double>(w.max_ns) / 1e3);
  out->close();
  out->deactivate();
  return 0;
}

// ---------------------------------------------------------------------------------------------
// Receiver (this process)
// ---------------------------------------------------------------------------------------------

struct Receiver;

// A servant with no RTM code: the floor of what any put(any) costs.
class BareInPort : public POA_RTM::InPort {
 public:
  explicit BareInPort(Receiver& receiver) : receiver_(receiver) {}
  void put(const CORBA::Any& value) override;
  char* name() override { return CORBA::string_dup("bare"); }
  CORBA::TypeCode_ptr port_type() override { return CORBA::TypeCode::_duplicate(RTM::_tc_TimedFloat6); }
  std::atomic<std::uint64_t> received{0};

 private:
  Receiver& receiver_;
};

struct Receiver {
  std::mutex mu;
  std::vector<std::int64_t> latency_ns;
  std::int64_t first_ns = 0;
  std::int64_t last_ns = 0;
  std::uint64_t count = 0;

  void reset(std::size_t expected) {
    std::lock_guard lock(mu);
    latency_ns.clear();
    latency_ns.reserve(expected);
    first_ns = last_ns = 0;
    count = 0;
  }
  void on_datum(const RTM::TimedFloat6& d) {
    const auto now = rtm_bench::monotonic_ns();
    if (stamp_ns(d) == 0) return;  // a warm-up datum
    std::lock_guard lock(mu);
    if (latency_ns.size() < latency_ns.capacity()) latency_ns.push_back(now - stamp_ns(d));
    if (count++ == 0) first_ns = now;
    last_ns = now;
  }
};

void BareInPort::put(const CORBA::Any& value) {
  const RTM::TimedFloat6* d = nullptr;
  if (!(value >>= d)) return;
  received.fetch_add(1, std::memory_order_relaxed);
  receiver_.on_datum(*d);
}

using rtm_bench::BusyNeighbour;  // another program on the machine

// The shm rows' floor on the receiving side: maps the ring a publisher hands it and nothing
// else (no InPort, no lock, no copy into a queue); a Poller reads it.
class BareRingPort : public virtual POA_RTM::InPortShm {
 public:
  void put(const CORBA::Any&) override { throw CORBA::NO_IMPLEMENT(); }
  void push(const CORBA::Any&) override {}
  void put_in_order(const CORBA::Any&, CORBA::ULongLong, CORBA::ULongLong) override { throw CORBA::NO_IMPLEMENT(); }
  void push_in_order(const CORBA::Any&, CORBA::ULongLong, CORBA::ULongLong) override {}
  char* name() override { return CORBA::string_dup("bare-ring"); }
  CORBA::TypeCode_ptr port_type() override { return CORBA::TypeCode::_duplicate(RTM::_tc_TimedFloat6); }
  char* owner() override { return CORBA::string_dup("receiver"); }
  RTM::PortCounters counters() override { return RTM::PortCounters{}; }
  char* last_error() override { return CORBA::string_dup(""); }
  RTM::PortDescription* describe() override { return new RTM::PortDescription; }
  void admit_writer() override {}
  char* reader_policy() override { return CORBA::string_dup("latest"); }
  CORBA::Boolean attach_ring(const char* segment, const char*, CORBA::ULongLong type_id, CORBA::Long,
                             CORBA::ULongLong, CORBA::String_out why) override {
    std::lock_guard lock(mu_);
    try {
      rtm::ShmSegment mapped = rtm::ShmSegment::open(segment);
      rtm::ShmRingReader reader(mapped.data(), mapped.size(), type_id);
      rings_.push_back(std::make_unique<Mapped>(Mapped{std::move(mapped), reader}));
    } catch (const std::exception& e) {
      why = CORBA::string_dup(e.what());
      return false;
    }
    current_.store(&rings_.back()->reader, std::memory_order_release);
    why = CORBA::string_dup("");
    return true;
  }
  // The mapping stays until this servant goes: the Poller may still be reading it.
  CORBA::Boolean detach_ring(const char*) override { return true; }
  // The ring attached last (nullptr before the first); read by one thread.
  rtm::ShmRingReader* current() { return current_.load(std::memory_order_acquire); }

 private:
  struct Mapped {
    rtm::ShmSegment segment;
    rtm::ShmRingReader reader;
  };
  std::mutex mu_;
  std::vector<std::unique_ptr<Mapped>> rings_;
  std::atomic<rtm::ShmRingReader*> current_{nullptr};
};

// A reader that takes data as fast as it can on a thread of its own (what a reader polling in
// its cycle sees, without the cycle): take() fills a datum and returns true for each new one.
class Poller {
 public:
  Poller(Receiver& receiver, std::function<bool(RTM::TimedFloat6&)> take)
      : thread_([this, &receiver, take = std::move(take)] {
          RTM::TimedFloat6 d{};
          while (!stop_.load(std::memory_order_relaxed)) {
            if (take(d)) receiver.on_datum(d);
          }
        }) {}
  ~Poller() {
    stop_.store(true);
    thread_.join();
  }

 private:
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// The on-arrival floor: a thread that waits on the bare ring's futex (wait_for_data) and takes
// each datum as it is woken, with nothing of the ports in between. A publisher child maps a
// new ring each slice: it waits for the one attached after it was made.
class RingWaiter {
 public:
  RingWaiter(Receiver& receiver, BareRingPort& port)
      : stale_(port.current()), thread_([this, &receiver, &port] {
          RTM::TimedFloat6 d{};
          while (!stop_.load()) {
            rtm::ShmRingReader* reader = reader_.load();
            if (reader == nullptr) {
              if (port.current() != stale_) reader_.store(port.current());
              else std::this_thread::sleep_for(std::chrono::microseconds(200));
              continue;
            }
            if (!reader->wait_for_data(rtm::ShmRingReader::kNoDeadline, &stop_)) continue;
            while (reader->take_next(std::as_writable_bytes(std::span(&d, 1))).status == rtm::ReadStatus::new_data)
              receiver.on_datum(d);
          }
        }) {}
  ~RingWaiter() {
    stop_.store(true);
    if (rtm::ShmRingReader* reader = reader_.load()) reader->interrupt();
    thread_.join();
  }

 private:
  rtm::ShmRingReader* const stale_;
  std::atomic<bool> stop_{false};
  std::atomic<rtm::ShmRingReader*> reader_{nullptr};
  std::thread thread_;
};

// Context switches of this process so far (voluntary + involuntary, every thread).
std::uint64_t context_switches() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<std::uint64_t>(u.ru_nvcsw + u.ru_nivcsw);
}

std::string run_child(const char* self, const std::vector<std::string>& child_args) {
  int fds[2];
  if (pipe(fds) != 0) return {};
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);
  posix_spawn_file_actions_addclose(&actions, fds[0]);
  std::vector<std::string> storage{self};
  storage.insert(storage.end(), child_args.begin(), child_args.end());
  std::vector<char*> argv;
  for (auto& s : storage) argv.push_back(s.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, self, &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  close(fds[1]);
  std::string output;
  if (rc == 0) {
    char buffer[4096];
    ssize_t n;
    while ((n = read(fds[0], buffer, sizeof(buffer))) > 0) output.append(buffer, static_cast<std::size_t>(n));
    int status = 0;
    waitpid(pid, &status, 0);
  }
  close(fds[0]);
  return output;
}

std::string result_line(const std::string& output) {
  const auto at = output.find("RESULT ");
  if (at == std::string::npos) return "(publisher failed: " + output + ")";
  return output.substr(at + 7, output.find('\n', at) - at - 7);
}

// One condition's rows (a transport, quiet or beside a busy neighbour), every figure beside
// the bare floor of the same condition.
struct Rows {
  const char* self;
  Receiver& receiver;
  std::string in_ior, bare_ior, tag;
  std::vector<std::string> common;
  std::size_t paced = 0, burst = 0;
  bool access_cost = false;  // --access-cost: only access_rows()

  std::string child(std::vector<std::string> extra) const {
    auto all = common;
    all.insert(all.end(), extra.begin(), extra.end());
    return run_child(self, all);
  }
  // Paced 1 kHz one-way latency through a publisher child in `mode` ("paced" or
  // "bare-paced"): one slice of `count` data, added to `latency_ns`; the slice's p50 [us]
  // and the publisher's line.
  std::pair<double, std::string> paced_slice(const std::string& ior, const std::string& mode,
                                             const std::string& delivery, std::size_t count,
                                             std::vector<std::int64_t>& latency_ns) {
    receiver.reset(count);
    const auto out = child({"--target", ior, "--mode", mode, "--delivery", delivery, "--count", std::to_string(count),
                            "--bare-timeout-ms", delivery == "timeout" ? "2" : "0", "--writer-timeout-ms",
                            delivery == "writer-unbounded" ? "0" : "2"});
    std::lock_guard lock(receiver.mu);
    std::vector<std::int64_t> slice = receiver.latency_ns;
    latency_ns.insert(latency_ns.end(), slice.begin(), slice.end());
    return {rtm_bench::summarize(slice).p50_us, result_line(out)};
  }
  // Data the receiver got from one publisher child in `mode`, and the time from its first to
  // its last (the same measure for RTM's rows and the bare one).
  struct Received {
    std::uint64_t count = 0;
    std::int64_t span_ns = 0;
    std::string publisher;
  };
  // timeout_ms: the bare rows' call timeout, or RTM's writer_call_timeout_ms.
  Received receive(const std::string& ior, const std::string& mode, std::size_t count, int timeout_ms = 0) {
    receiver.reset(0);
    const auto ms = std::to_string(timeout_ms);
    const auto out = child({"--target", ior, "--mode", mode, "--count", std::to_string(count), "--bare-timeout-ms", ms,
                            "--writer-timeout-ms", ms});
    std::lock_guard lock(receiver.mu);
    return {receiver.count, receiver.last_ns - receiver.first_ns, result_line(out)};
  }
  static double rate(std::uint64_t count, std::int64_t span_ns) {
    return span_ns > 0 ? static_cast<double>(count) / (static_cast<double>(span_ns) / 1e9) : 0.0;
  }
  // One rate row, as the receiver saw it.
  double rate_row(const std::string& label, const std::string& mode, std::size_t count) {
    const Received r = receive(in_ior, mode, count, 2);  // write()'s default bound
    const double per_s = rate(r.count, r.span_ns);
    std::printf("%s %-38s %9.0f msg/s received (%llu of %zu written)\n", tag.c_str(), label.c_str(), per_s,
                static_cast<unsigned long long>(r.count), count);
    std::printf("%-44s publisher: %s\n", "", r.publisher.c_str());
    return per_s;
  }

  // The paced rows in kSlices alternating slices (a new publisher process each), so that each
  // row sees the same machine; the spread of the per-slice p50 ratios is printed beside the
  // pooled figures.
  static constexpr std::size_t kSlices = 10;
  void paced_rows() {
    struct Paced {
      const char* label;
      std::string ior, mode, delivery;
      std::vector<std::int64_t> latency_ns;
      std::vector<double> slice_p50_us;
      std::string last_publisher_line;
    };
    std::array<Paced, 5> rows{{{"RTM one-way, paced 1 kHz, write() calls", in_ior, "paced", "writer", {}, {}, {}},
                               {"RTM one-way, paced 1 kHz, delivery thread", in_ior, "paced", "thread", {}, {}, {}},
                               {"bare omniORB put(any) one-way, paced 1 kHz", bare_ior, "bare-paced", "", {}, {}, {}},
                               {"bare put(any), 2 ms call timeout set", bare_ior, "bare-paced", "timeout", {}, {}, {}},
                               {"RTM write() calls, its bound off", in_ior, "paced", "writer-unbounded", {}, {}, {}}}};
    for (std::size_t slice = 0; slice < kSlices; ++slice) {
      for (Paced& row : rows) {
        auto [p50, line] = paced_slice(row.ior, row.mode, row.delivery, paced / kSlices, row.latency_ns);
        row.slice_p50_us.push_back(p50);
        row.last_publisher_line = line;
      }
    }
    std::array<rtm_bench::Summary, 5> summary;
    for (std::size_t i = 0; i < rows.size(); ++i) {
      summary[i] = rtm_bench::summarize(rows[i].latency_ns);
      rtm_bench::print_row((tag + " " + rows[i].label).c_str(), summary[i]);
      std::printf("%-44s publisher (last of %zu slices): %s\n", "", kSlices, rows[i].last_publisher_line.c_str());
    }
    const auto& [by_writer, by_thread, bare, bare_timeout, unbounded] = summary;
    std::printf("%s   ratio to bare, p50 / p99: write() calls %.2f / %.2f, delivery thread %.2f / %.2f, bare with a "
                "call timeout %.2f / %.2f, write() with its bound off %.2f / %.2f\n",
                tag.c_str(), by_writer.p50_us / bare.p50_us, by_writer.p99_us / bare.p99_us,
                by_thread.p50_us / bare.p50_us, by_thread.p99_us / bare.p99_us, bare_timeout.p50_us / bare.p50_us,
                bare_timeout.p99_us / bare.p99_us, unbounded.p50_us / bare.p50_us, unbounded.p99_us / bare.p99_us);
    std::vector<double> slice_ratio;
    for (std::size_t k = 0; k < kSlices; ++k) slice_ratio.push_back(rows[0].slice_p50_us[k] / rows[2].slice_p50_us[k]);
    std::sort(slice_ratio.begin(), slice_ratio.end());
    std::printf("%s   write() calls / bare p50, slice by slice: median %.2f, range %.2f-%.2f (%zu slices)\n",
                tag.c_str(), slice_ratio[kSlices / 2], slice_ratio.front(), slice_ratio.back(), kSlices);
  }

  // Twoway, every datum: RTM's and the bare burst in alternating slices, each rate as the
  // receiver saw it (slices summed: data over time).
  static constexpr std::size_t kBurstSlices = 4;
  void burst_rows() {
    struct Burst {
      const char* label;
      std::string ior, mode;
      int timeout_ms;
      std::uint64_t count = 0;
      std::int64_t span_ns = 0;
      std::string publisher;
    };
    std::array<Burst, 4> rows{{{"RTM burst, put (twoway), every datum", in_ior, "burst", 2, 0, 0, {}},
                               {"RTM burst, write()'s bound off", in_ior, "burst", 0, 0, 0, {}},
                               {"bare put(any) back to back", bare_ior, "bare-burst", 0, 0, 0, {}},
                               {"bare, 2 ms call timeout set", bare_ior, "bare-burst", 2, 0, 0, {}}}};
    for (std::size_t slice = 0; slice < kBurstSlices; ++slice) {
      for (Burst& row : rows) {
        const Received r = receive(row.ior, row.mode, burst / kBurstSlices, row.timeout_ms);
        row.count += r.count;
        row.span_ns += r.span_ns;
        row.publisher = r.publisher;
      }
    }
    std::array<double, 4> per_s{};
    for (std::size_t i = 0; i < rows.size(); ++i) {
      per_s[i] = rate(rows[i].count, rows[i].span_ns);
      std::printf("%s %-38s %9.0f msg/s received (%llu of %zu)\n", tag.c_str(), rows[i].label, per_s[i],
                  static_cast<unsigned long long>(rows[i].count), burst);
      std::printf("%-44s publisher (last slice): %s\n", "", rows[i].publisher.c_str());
    }
    const double bare = per_s[2] > 0 ? per_s[2] : 1.0;
    std::printf("%s   ratio to bare, twoway every datum: RTM %.2f, RTM bound off %.2f, bare with a call timeout %.2f\n",
                tag.c_str(), per_s[0] / bare, per_s[1] / bare, per_s[3] / bare);
  }

  // What access control's check costs a change request (host/access.h): the same bare put with
  // the receiver owner-only (the caller's user, found when the connection was accepted, looked
  // up for each put) and open to all (no lookup), in alternating slices of one run; each slice
  // is a new publisher process, so each includes a new connection and its accept.
  void access_rows() {
    struct Policy {
      const char* label;
      rtm::AccessPolicy policy;
      std::vector<std::int64_t> latency_ns;
      std::uint64_t count = 0;
      std::int64_t span_ns = 0;
    };
    std::array<Policy, 2> rows{{{"bare put, receiver open (no check)", rtm::AccessPolicy::open, {}, 0, 0},
                                {"bare put, receiver owner-only (check)", rtm::AccessPolicy::owner, {}, 0, 0}}};
    // The order flips every slice (ABBA): a row that always came second would pay for the
    // previous publisher process's exit more often.
    for (std::size_t slice = 0; slice < kSlices; ++slice) {
      for (std::size_t k = 0; k < rows.size(); ++k) {
        Policy& row = rows[slice % 2 == 0 ? k : rows.size() - 1 - k];
        rtm::configure_access(row.policy);
        paced_slice(bare_ior, "bare-paced", "", paced / kSlices, row.latency_ns);
      }
    }
    for (std::size_t slice = 0; slice < kBurstSlices; ++slice) {
      for (std::size_t k = 0; k < rows.size(); ++k) {
        Policy& row = rows[slice % 2 == 0 ? k : rows.size() - 1 - k];
        rtm::configure_access(row.policy);
        const Received r = receive(bare_ior, "bare-burst", burst / kBurstSlices, 0);
        row.count += r.count;
        row.span_ns += r.span_ns;
      }
    }
    rtm::configure_access(rtm::AccessPolicy::open);
    std::array<rtm_bench::Summary, 2> summary;
    for (std::size_t i = 0; i < rows.size(); ++i) {
      summary[i] = rtm_bench::summarize(rows[i].latency_ns);
      rtm_bench::print_row((tag + " " + rows[i].label).c_str(), summary[i]);
      std::printf("%s %-38s %9.0f msg/s twoway back to back\n", tag.c_str(), rows[i].label,
                  rate(rows[i].count, rows[i].span_ns));
    }
    std::printf("%s   owner-only / open: one-way p50 %.2f, p99 %.2f; twoway rate %.2f\n", tag.c_str(),
                summary[1].p50_us / summary[0].p50_us, summary[1].p99_us / summary[0].p99_us,
                rate(rows[1].count, rows[1].span_ns) / rate(rows[0].count, rows[0].span_ns));
  }

  void run() {
    if (access_cost) {
      access_rows();
      return;
    }
    paced_rows();
    burst_rows();
    rate_row("RTM stream, push (oneway), pipelined", "stream-oneway", burst);
    rate_row("RTM flood, writer never waits, 1 s", "flood", burst);
  }
};

// The same-host path (--transport shm): RTM's ports through the port's ring beside the bare
// ring, each read by a Poller here, paced in alternating slices and then back to back.
struct ShmRows {
  Rows& rows;
  std::string ring_ior, bare_ring_ior;
  Float6In& in_ring;  // FIFO: reads the port's ring
  BareRingPort& bare_ring;
  std::atomic<std::uint64_t> bare_missed{0};

  // batch: the port is read with read_many() into a buffer of 256 (one lock per batch), as a
  // reader that drains its FIFO each cycle does.
  std::function<bool(RTM::TimedFloat6&)> taker(bool bare, bool batch = false) {
    if (!bare && batch) {
      struct Buffer {
        std::array<RTM::TimedFloat6, 256> data{};
        std::size_t next = 0, size = 0;
      };
      auto buffer = std::make_shared<Buffer>();
      return [this, buffer](RTM::TimedFloat6& d) {
        if (buffer->next == buffer->size) {
          buffer->size = in_ring.read_many(buffer->data);
          buffer->next = 0;
          if (buffer->size == 0) return false;
        }
        d = buffer->data[buffer->next++];
        return true;
      };
    }
    if (!bare) return [this](RTM::TimedFloat6& d) { return in_ring.read(d) == rtm::ReadResult::NewData; };
    return [this](RTM::TimedFloat6& d) {
      rtm::ShmRingReader* reader = bare_ring.current();
      if (reader == nullptr) return false;
      const rtm::RingRead r = reader->take_next(std::as_writable_bytes(std::span(&d, 1)));
      bare_missed.fetch_add(r.missed, std::memory_order_relaxed);
      return r.status == rtm::ReadStatus::new_data;
    };
  }

  void paced() {
    struct Paced {
      const char* label;
      bool bare;
      std::vector<std::int64_t> latency_ns;
      std::string publisher;
    };
    std::array<Paced, 2> paced_rows{{{"RTM shm, paced 1 kHz, reader polling", false, {}, {}},
                                     {"bare ring, paced 1 kHz, reader polling", true, {}, {}}}};
    for (std::size_t slice = 0; slice < Rows::kSlices; ++slice) {
      for (Paced& row : paced_rows) {
        Poller poller(rows.receiver, taker(row.bare));
        row.publisher = rows.paced_slice(row.bare ? bare_ring_ior : ring_ior, row.bare ? "ring-paced" : "paced",
                                         "writer", rows.paced / Rows::kSlices, row.latency_ns)
                            .second;
      }
    }
    std::array<rtm_bench::Summary, 2> summary;
    for (std::size_t i = 0; i < paced_rows.size(); ++i) {
      summary[i] = rtm_bench::summarize(paced_rows[i].latency_ns);
      rtm_bench::print_row((rows.tag + " " + paced_rows[i].label).c_str(), summary[i]);
      std::printf("%-44s publisher (last slice): %s\n", "", paced_rows[i].publisher.c_str());
    }
    std::printf("%s   RTM shm / bare ring, p50 %.2f, p99 %.2f\n", rows.tag.c_str(), summary[0].p50_us / summary[1].p50_us,
                summary[0].p99_us / summary[1].p99_us);
  }

  // On arrival: the receiver's callback InPort reads the port's ring with a waiter thread of its
  // own (woken by the writer's futex wake), beside the bare ring's futex wait, paced at 1 kHz in
  // alternating slices; with the receiver's context switches per datum.
  void on_arrival() {
    struct Paced {
      const char* label;
      bool bare;
      std::vector<std::int64_t> latency_ns;
      std::uint64_t switches = 0;
      std::string publisher;
    };
    std::array<Paced, 2> paced_rows{{{"RTM shm, paced 1 kHz, callback on arrival", false, {}, 0, {}},
                                     {"bare ring, paced 1 kHz, futex wait", true, {}, 0, {}}}};
    for (std::size_t slice = 0; slice < Rows::kSlices; ++slice) {
      for (Paced& row : paced_rows) {
        std::optional<RingWaiter> waiter;
        if (row.bare) waiter.emplace(rows.receiver, bare_ring);
        const std::uint64_t before = context_switches();
        row.publisher = rows.paced_slice(row.bare ? bare_ring_ior : rows.in_ior, row.bare ? "ring-paced" : "paced",
                                         "writer", rows.paced / Rows::kSlices, row.latency_ns)
                            .second;
        row.switches += context_switches() - before;
      }
    }
    std::array<rtm_bench::Summary, 2> summary;
    for (std::size_t i = 0; i < paced_rows.size(); ++i) {
      summary[i] = rtm_bench::summarize(paced_rows[i].latency_ns);
      rtm_bench::print_row((rows.tag + " " + paced_rows[i].label).c_str(), summary[i]);
      const double data = static_cast<double>(paced_rows[i].latency_ns.size());
      std::printf("%-44s context switches per datum in the receiver: %.2f; publisher (last slice): %s\n", "",
                  data > 0 ? static_cast<double>(paced_rows[i].switches) / data : 0.0,
                  paced_rows[i].publisher.c_str());
    }
    std::printf("%s   RTM on arrival / bare futex wait, p50 %.2f, p99 %.2f\n", rows.tag.c_str(),
                summary[0].p50_us / summary[1].p50_us, summary[0].p99_us / summary[1].p99_us);
  }

  void stream() {
    struct Stream {
      const char* label;
      bool bare, batch;
      std::uint64_t count = 0, written = 0, lost = 0;
      std::int64_t span_ns = 0;
      std::string publisher;
    };
    std::array<Stream, 3> stream_rows{{{"RTM shm, writer back to back", false, false, 0, 0, 0, 0, {}},
                                       {"RTM shm, the same, read_many()", false, true, 0, 0, 0, 0, {}},
                                       {"bare ring, writer back to back", true, false, 0, 0, 0, 0, {}}}};
    for (std::size_t slice = 0; slice < Rows::kBurstSlices; ++slice) {
      for (Stream& row : stream_rows) {
        const std::uint64_t dropped_before = in_ring.counters_snapshot().dropped, missed_before = bare_missed.load();
        {
          Poller poller(rows.receiver, taker(row.bare, row.batch));
          const auto r = rows.receive(row.bare ? bare_ring_ior : ring_ior, row.bare ? "ring-stream" : "stream-oneway",
                                      rows.burst / Rows::kBurstSlices, 2);
          row.count += r.count;
          row.span_ns += r.span_ns;
          row.written += rows.burst / Rows::kBurstSlices;
          row.publisher = r.publisher;
        }
        row.lost += row.bare ? bare_missed.load() - missed_before : in_ring.counters_snapshot().dropped - dropped_before;
      }
    }
    std::array<double, 3> per_s{};
    for (std::size_t i = 0; i < stream_rows.size(); ++i) {
      const Stream& row = stream_rows[i];
      per_s[i] = Rows::rate(row.count, row.span_ns);
      std::printf("%s %-38s %9.0f msg/s taken in order (%llu of %llu; %llu overwritten before the reader took them)\n",
                  rows.tag.c_str(), row.label, per_s[i], static_cast<unsigned long long>(row.count),
                  static_cast<unsigned long long>(row.written), static_cast<unsigned long long>(row.lost));
      std::printf("%-44s publisher (last slice): %s\n", "", row.publisher.c_str());
    }
    const double bare = per_s[2] > 0 ? per_s[2] : 1.0;
    std::printf("%s   RTM shm / bare ring, taken per second: read() %.2f, read_many() %.2f\n", rows.tag.c_str(),
                per_s[0] / bare, per_s[1] / bare);
  }
};

int run_receiver(const char* self, const Args& args) {
  const int cpu = static_cast<int>(args.number("--cpu", -1));
  pin(cpu);
  const std::string which = args.get("--transport", "both");
  const std::string neighbour = args.get("--neighbour", "none");
  rtm::log().set_level(spdlog::level::warn);

  const bool ssl = which == "ssl" || which == "all";
  const std::filesystem::path tls_folder =
      std::filesystem::temp_directory_path() / ("rtm-bench-tls-" + std::to_string(::getpid()));
  std::vector<std::string> endpoints{"-ORBendPoint", "giop:tcp:127.0.0.1:", "-ORBendPoint", "giop:unix:"};
  if (ssl) {
    std::filesystem::remove_all(tls_folder);
    rtm::make_tls_authority(tls_folder, "bench", "bench", 1);
    rtm::configure_tls(rtm::check_tls_folder(tls_folder));
    endpoints.insert(endpoints.end(), {"-ORBendPoint", "giop:ssl:127.0.0.1:"});
  }
  // Over plain TCP nobody can tell who calls (host/access.h): the receiver lets anyone put, as
  // a component started with --access open does. What the owner-only check costs over
  // giop:unix: is measured by --access-cost.
  rtm::configure_access(rtm::AccessPolicy::open);
  rtm::Orb orb(endpoints);
  Receiver receiver;
  PortableServer::Servant_var<Float6In> in(new Float6In(
      "in", "receiver",
      rtm::InPortPolicy::callback<RTM::TimedFloat6>([&](const RTM::TimedFloat6& d) { receiver.on_datum(d); })));
  RTM::InPortEx_var in_ref = in->activate(orb);
  PortableServer::Servant_var<BareInPort> bare(new BareInPort(receiver));
  CORBA::Object_var bare_ref = orb.activate(bare.in());
  // The shm rows' ports: a FIFO that holds all the ring does (so that a lost datum is one the
  // ring overwrote, as for the bare reader), and the bare ring's servant.
  PortableServer::Servant_var<Float6In> in_ring(new Float6In("ring", "receiver", rtm::InPortPolicy::fifo(2 * rtm::kMinRingSlots)));
  RTM::InPortEx_var in_ring_ref = in_ring->activate(orb);
  PortableServer::Servant_var<BareRingPort> bare_ring(new BareRingPort);
  CORBA::Object_var bare_ring_ref = orb.activate(bare_ring.in());

  std::printf("two processes, TimedFloat6, %s\n", cpu >= 0 ? ("both pinned to CPU " + std::to_string(cpu)).c_str()
                                                            : "unpinned");
  for (const std::string transport : {"tcp", "unix", "ssl", "shm"}) {
    const bool listed = ("," + which + ",").find("," + transport + ",") != std::string::npos;
    const bool chosen = listed || which == "all" || (which == "both" && (transport == "tcp" || transport == "unix"));
    if (!chosen) continue;
    for (const std::string busy : {"none", "busy"}) {
      if (neighbour != "both" && neighbour != busy) continue;
      Rows rows{self, receiver, orb.to_string(in_ref), orb.to_string(bare_ref),
                "[" + transport + (busy == "busy" ? ", busy neighbour]" : "]"),
                {"--role", "publisher", "--transport", transport, "--cpu", std::to_string(cpu), "--tls",
                 tls_folder.string()},
                static_cast<std::size_t>(args.number("--paced", 5000)),
                static_cast<std::size_t>(args.number("--burst", 200000)),
                args.get("--access-cost", "0") != "0"};
      std::optional<BusyNeighbour> load;
      if (busy == "busy") load.emplace();
      if (transport == "shm") {
        ShmRows shm{rows, orb.to_string(in_ring_ref), orb.to_string(bare_ring_ref), *in_ring, *bare_ring};
        shm.paced();
        shm.on_arrival();
        shm.stream();
        continue;
      }
      rows.run();
    }
  }
  in->deactivate();
  in_ring->deactivate();
  orb.deactivate(bare.in());
  orb.deactivate(bare_ring.in());
  if (ssl) std::filesystem::remove_all(tls_folder);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const Args args = parse(argc, argv);
  if (args.get("--role", "receiver") == "publisher") return run_publisher(args);
  return run_receiver("/proc/self/exe", args);
}
