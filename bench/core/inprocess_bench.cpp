// SPDX-License-Identifier: Apache-2.0
// In-process port path: OutPort<TimedFloat6>::write -> InPort<TimedFloat6> of the same
// process, without any nor ORB (the subscription found the InPort local).
//
//   rtm_bench_inprocess [--count N]
//
// Rows:
//   direct, write+read       latest-policy InPort filled by write() itself; one write and one
//                            read per message in the same thread (throughput and latency)
//   direct, stamp derived    the same, the OutPort deriving its stamp from an InPort the
//                            thread read (OutPortBase::derive_stamp_from: one more copy of
//                            the datum per write), as inside a chain
//   via subscribe(ref)       the same, but connected through subscribe() with the InPort's
//                            CORBA reference, as a remote tool would connect two components
//                            of one process
//   callback, hand-off       callback-policy InPort: write() wakes the delivery thread which
//                            runs the callback (a thread hand-off per message)
#include "bench_stats.h"

#include "rtm/inport.h"
#include "rtm/orb.h"
#include "rtm/outport.h"

#include <sched.h>

#include <atomic>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>

namespace {

using Float6In = rtm::InPort<RTM::TimedFloat6>;
using Float6Out = rtm::OutPort<RTM::TimedFloat6>;

void write_read_run(const char* label, Float6Out& out, Float6In& in, std::size_t count) {
  RTM::TimedFloat6 datum{};
  RTM::TimedFloat6 got{};
  std::vector<std::int64_t> latency_ns(count);
  // Warm up caches and the branch predictor.
  for (std::size_t i = 0; i < 10000; ++i) {
    out.write(datum);
    in.read(got);
  }
  std::size_t misses = 0;
  const auto start = rtm_bench::monotonic_ns();
  for (std::size_t i = 0; i < count; ++i) {
    datum.val[0] = static_cast<float>(i);
    const auto before = rtm_bench::monotonic_ns();
    out.write(datum);
    if (in.read(got) != rtm::ReadResult::NewData) ++misses;
    latency_ns[i] = rtm_bench::monotonic_ns() - before;
  }
  const auto elapsed_ns = rtm_bench::monotonic_ns() - start;
  // Throughput without the two clock reads per message.
  const auto bare_start = rtm_bench::monotonic_ns();
  for (std::size_t i = 0; i < count; ++i) {
    datum.val[0] = static_cast<float>(i);
    out.write(datum);
    if (in.read(got) != rtm::ReadResult::NewData) ++misses;
  }
  const auto bare_elapsed_ns = rtm_bench::monotonic_ns() - bare_start;
  auto summary = rtm_bench::summarize(latency_ns);
  rtm_bench::print_row(label, summary);
  std::printf("%-44s %.2f M msg/s (%.2f M msg/s with timing), %zu misses\n", "",
              static_cast<double>(count) / (static_cast<double>(bare_elapsed_ns) / 1e9) / 1e6,
              static_cast<double>(count) / (static_cast<double>(elapsed_ns) / 1e9) / 1e6, misses);
}

void callback_run(std::size_t count) {
  std::vector<std::int64_t> latency_ns;
  latency_ns.reserve(count);
  std::atomic<std::uint64_t> received{0};
  PortableServer::Servant_var<Float6In> in(new Float6In(
      "in", "bench", rtm::InPortPolicy::callback<RTM::TimedFloat6>([&](const RTM::TimedFloat6& d) {
        const std::int64_t sent_ns = std::int64_t{d.tm.sec} * 1'000'000'000 + d.tm.nsec;
        if (latency_ns.size() < latency_ns.capacity()) latency_ns.push_back(rtm_bench::monotonic_ns() - sent_ns);
        received.fetch_add(1, std::memory_order_release);
      })));
  PortableServer::Servant_var<Float6Out> out(new Float6Out("out", "bench"));
  out->connect(*in);
  RTM::TimedFloat6 datum{};
  for (std::size_t i = 0; i < count; ++i) {
    // Paced: one message in flight, so each sample is one hand-off, not a queue.
    const auto now = rtm_bench::monotonic_ns();
    datum.tm.sec = static_cast<CORBA::ULong>(now / 1'000'000'000);
    datum.tm.nsec = static_cast<CORBA::ULong>(now % 1'000'000'000);
    out->write(datum);
    const auto deadline = now + 1'000'000'000;
    while (received.load(std::memory_order_acquire) <= i && rtm_bench::monotonic_ns() < deadline) {
      std::this_thread::yield();
    }
  }
  out->close();
  rtm_bench::print_row("callback, hand-off to delivery thread", rtm_bench::summarize(latency_ns));
}

}  // namespace

int main(int argc, char** argv) {
  std::size_t count = 2'000'000;
  for (int i = 1; i + 1 < argc; ++i) {
    if (std::strcmp(argv[i], "--count") == 0) count = std::strtoull(argv[i + 1], nullptr, 10);
  }
  rtm::Orb orb({"-ORBendPoint", "giop:tcp:127.0.0.1:"});
  std::printf("in-process TimedFloat6, %zu messages per row\n", count);

  {
    PortableServer::Servant_var<Float6In> in(new Float6In("in", "bench"));
    PortableServer::Servant_var<Float6Out> out(new Float6Out("out", "bench"));
    out->connect(*in);
    write_read_run("direct (connect), write+read", *out, *in, count);
    out->close();
  }
  {
    PortableServer::Servant_var<Float6In> source(new Float6In("source", "bench"));
    PortableServer::Servant_var<Float6In> in(new Float6In("in", "bench"));
    PortableServer::Servant_var<Float6Out> out(new Float6Out("out", "bench"));
    RTM::TimedFloat6 sample{};
    sample.tm.sec = 1;
    source->deliver(sample);
    source->read(sample);
    out->derive_stamp_from({source.in()});
    out->connect(*in);
    write_read_run("direct, stamp derived, write+read", *out, *in, count);
    out->close();
  }
  {
    PortableServer::Servant_var<Float6In> in(new Float6In("in", "bench"));
    PortableServer::Servant_var<Float6Out> out(new Float6Out("out", "bench"));
    RTM::InPortEx_var in_ref = in->activate(orb);
    RTM::OutPortEx_var out_ref = out->activate(orb);
    if (!out_ref->subscribe(RTM::repeated, in_ref)) {
      std::fprintf(stderr, "subscribe refused: %s\n", out->last_error_text().c_str());
      return 1;
    }
    RTM::SubscriptionInfoList_var subs = out_ref->subscriptions();
    std::printf("subscribe(ref): in_process=%s\n", subs->length() == 1 && subs[0].in_process ? "true" : "false");
    write_read_run("via subscribe(ref), write+read", *out, *in, count);
    out->close();
    out->deactivate();
    in->deactivate();
  }
  callback_run(std::min<std::size_t>(count, 100'000));
  return 0;
}
