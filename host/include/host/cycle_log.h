// SPDX-License-Identifier: Apache-2.0
// A component's cycles in an MCAP file, and the component's logic run again against them
// (docs/recording.md, "Re-simulation").
//
// The log (the runner's --log-cycles FILE) taps every port of the component (rtm/cycle_tap.h).
// Each start, cycle and stop is a group: a message on the channel "cycles" (JSON: the cycle's
// context, and which port each read and write went to, in order, with what each read
// returned), and one message per datum a read gave or a write wrote, on the port's channel
// (named "<component>.<port>", the port's IDL as omgidl schema, CDR as RTM record writes it),
// all with the group's number as sequence and its due time (CLOCK_MONOTONIC) as log time. The
// cycle thread only copies the datum into a slot and an event into a ring; a writer thread
// (SCHED_OTHER) turns them into MCAP every 10 ms. What finds the ring or the slots full is lost,
// counted, and marked in its group: a replay then says which cycles it cannot judge.
//
// A replay builds the component afresh (its module and options), with no activity: it turns it
// on, steps it through every logged cycle with that cycle's context, each read answered by what
// the log says it returned then, and compares every write with the logged one, byte for byte.
#pragma once

#include "rtm/component.h"
#include "rtm/cycle_tap.h"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <mutex>
#include <set>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace rtm {

namespace mcap {
class Writer;
}

struct CycleLogOptions {
  std::uint32_t slots_per_port = 1024;  // data a port may have waiting for the writer thread
  std::chrono::milliseconds write_every{10};  // how often the writer thread takes what waits
};

class CycleLog final : public TapSink, public CycleObserver {
 public:
  // Taps every port of servant's component and opens `path` (mode 0600, never through a
  // symbolic link; replaced if there). Before on(). Throws std::system_error for the file,
  // std::invalid_argument for a port type with no omgidl reading.
  CycleLog(ComponentServant& servant, const std::string& path, CycleLogOptions options = {});
  // After off(): detaches, writes what is left and the end (the lost count, the parameters
  // at the end), closes the file.
  ~CycleLog() override;
  CycleLog(const CycleLog&) = delete;
  CycleLog& operator=(const CycleLog&) = delete;

  // Events or data that found no room (the writer fell behind).
  std::uint64_t lost() const { return lost_.load(std::memory_order_relaxed); }
  // Waits until what was logged so far is in the file (not for the cycle thread).
  void flush();

  // ---- the cycle thread ----
  void tapped(std::uint16_t port, TapEvent event, ReadResult result, std::uint32_t slot,
              std::uint32_t count) noexcept override;
  void starting() noexcept override;
  void cycle(const CycleContext& ctx) noexcept override;
  void stopping() noexcept override;

 private:
  struct Event {
    std::uint8_t kind = 0;  // Kind
    std::uint8_t result = 0;
    std::uint16_t port = 0;
    std::uint32_t slot = 0;
    std::uint32_t count = 0;
    std::uint64_t cycle = 0;
    std::int64_t deadline_ns = 0, wake_ns = 0, period_ns = 0;
    std::uint32_t lost_before = 0;  // events lost just before this one (the ring was full)
  };
  struct Port {
    std::string name;  // "<component>.<port>"
    bool in = false;
    std::unique_ptr<PortTap> tap;
    std::uint16_t channel = 0;
  };
  void push(const Event& e) noexcept;
  void push_edge(std::uint8_t kind) noexcept;
  void run();
  void drain();
  void drain_locked();
  void write(const Event& e);
  void end_group();

  ComponentServant& servant_;
  std::vector<Port> ports_;
  std::unique_ptr<mcap::Writer> writer_;
  std::uint16_t cycles_channel_ = 0;
  std::vector<Event> ring_;
  std::uint64_t head_ = 0;  // the cycle thread's
  std::uint32_t lost_unpushed_ = 0;  // the cycle thread's
  std::atomic<std::uint64_t> published_{0};
  std::atomic<std::uint64_t> taken_{0};
  std::atomic<std::uint64_t> lost_{0};
  CycleLogOptions options_;
  std::condition_variable wake_;
  bool stop_ = false;  // under flush_mu_
  // The writer thread's: the group being written.
  bool group_open_ = false;
  std::uint8_t group_kind_ = 0;
  std::uint32_t group_number_ = 0;
  std::uint64_t group_cycle_ = 0;
  std::int64_t group_deadline_ns_ = 0, group_wake_ns_ = 0, group_period_ns_ = 0;
  std::string group_reads_, group_writes_;
  std::uint64_t group_lost_ = 0;
  std::vector<std::uint8_t> scratch_;
  std::string error_;
  std::mutex flush_mu_;
  std::thread thread_;
};

// What a replay found.
struct ReplayMismatch {
  std::string port;        // "<component>.<port>"
  std::uint64_t cycle = 0;  // the cycle's number (groups "start"/"stop": as the log says)
  std::string group;       // "start", "cycle" or "stop"
  std::int64_t deadline_ns = 0;
  std::size_t index = 0;   // the write's index within its group on that port
  std::vector<std::uint8_t> logged, replayed;  // CDR; empty: that side wrote nothing there
};

struct ReplayResult {
  std::string component;      // as logged
  std::uint64_t cycles = 0;   // cycles stepped
  std::uint64_t writes = 0;   // writes compared
  std::uint64_t differing = 0;  // of them, or written on one side only
  std::uint64_t unjudged = 0;   // cycles the log lost part of (not compared)
  std::uint64_t unanswered_reads = 0;  // reads the replay made beyond the log's
  std::uint64_t unused_answers = 0;    // logged reads the replay did not make
  std::int64_t logged_span_ns = 0;     // first to last cycle's due time
  double replay_seconds = 0;           // the stepping alone (not reading the log)
  std::vector<ReplayMismatch> mismatches;  // the first ReplayOptions::keep of them, in order
  std::map<std::string, CORBA::TypeCode_var> types;  // each out port's, to decode them
  std::map<std::string, std::vector<std::string>> elements;  // each out port's element names, if described
  std::vector<std::string> warnings;  // e.g. a parameter the run changed while on
};

// What a log says of the component it came from: to build it again.
struct CycleLogInfo {
  std::string component, kind;
  std::map<std::string, std::string> parameters;  // at the start, as set_parameter takes them
  std::map<std::string, std::string> parameters_at_end;
  std::uint64_t lost = 0;
};
// Throws std::runtime_error for a file that is not a whole cycle log (mcap::FormatError, or
// its metadata missing).
CycleLogInfo read_cycle_log_info(const std::string& log);

struct ReplayOptions {
  std::string output;  // the replayed writes as MCAP ("": none)
  // Set before on(), after the logged ones (a parameter fixed at build time is checked against
  // the logged value instead: a difference is an error naming it).
  std::map<std::string, std::string> parameters;
  // Parameters the component was built with on purpose (its options): kept, not set from the log.
  std::set<std::string> keep_built;
  std::size_t keep = 1000;  // mismatches kept in the result
};

// Steps `component` (built afresh, named as logged; no activity) through the log. Needs the
// process's ORB (rtm/cdr.h). Throws std::runtime_error for a log it cannot follow: another
// component's, a port it does not have or of another type, a malformed group.
ReplayResult replay_cycle_log(std::unique_ptr<Component> component, const std::string& log,
                              const ReplayOptions& options = {});

}  // namespace rtm
