// SPDX-License-Identifier: Apache-2.0
// `rtm record`: OutPorts' data into an MCAP file that carries its own types.
//
// Each port gets a channel named by its address ("sensor0.out0"), its type's IDL as an omgidl
// schema (rtm/cdr.h, user types included), and in the channel's metadata the type, the
// elements' names and units. Each datum is written as CDR with its own stamp (its `tm`) as log
// time and the moment it reached the recorder as publish time. The file's metadata holds the
// running system as a system file `rtm up` takes ("rtm.system"), and at the end what each port
// lost and where ("rtm.drops"): drops are counted and written, never hidden.
//
// The recorder is a subscriber like any other (a WatchPort): on this host it reads the
// publisher's shared-memory ring, so no datum waits on it and a writer is never held up; what
// it cannot keep up with is counted as dropped. A chunk reaches the file at least every
// `flush_every`, so a recorder that is killed loses at most that much (mcap::recover reads the
// rest). A stop request (Ctrl-C, SIGTERM) ends with a whole file.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "browser/browser.h"
#include "mcap/records.h"
#include "rtm/orb.h"

namespace rtm::cli {

struct RecordOptions {
  std::vector<std::string> ports;  // "<component>.<OutPort>"
  bool all = false;                // and every OutPort of every component running
  std::string output;              // the .mcap file
  bool overwrite = false;          // else an existing output is refused
  mcap::Compression compression = mcap::Compression::zstd;
  double duration_s = 0;  // stop after this long (0: until stopped)
  long count = 0;         // stop after this many data in all (0: no limit)
  std::chrono::milliseconds flush_every{1000};
};

// What one port gave, and what it lost.
struct RecordedPort {
  std::string address;
  std::string type;
  std::string path;                         // "shared memory" or "CORBA"
  std::uint64_t recorded = 0;
  unsigned long long dropped_by_publisher = 0;  // the publisher's count for this subscriber
  std::uint64_t dropped_by_recorder = 0;    // arrived while the recorder's queue was full
  std::uint64_t late = 0;                   // after a later datum of its sender
  std::uint64_t wrong_type = 0;
};

struct RecordResult {
  std::vector<RecordedPort> ports;
  double seconds = 0;
  std::uint64_t bytes = 0;  // the file's size
  std::vector<std::string> left_out;  // components the system metadata could not hold, with why
};

// Records until `stop` returns true (asked a few times a second) or a limit is reached.
// Throws BrowseError for a port that is not an OutPort or refuses the subscription,
// std::invalid_argument for a type with no omgidl reading or an output that exists, and
// std::system_error when the file cannot be written. `progress` gets one line per step.
RecordResult record(const Browser& browser, rtm::Orb& orb, const RecordOptions& options,
                    const std::function<bool()>& stop, const std::function<void(const std::string&)>& progress);

}  // namespace rtm::cli
