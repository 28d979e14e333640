// SPDX-License-Identifier: Apache-2.0
// ConnPolicy: how one connection from an OutPort to an InPort behaves, as one value (Orocos
// RTT's ConnPolicy is the model). subscribe/connect take it, `rtm ls -l`/`rtm cat` show it
// per subscription, system files keep it as text:
//
//   repeated                 the subscription lives until unsubscribed (RTM.idl's repeated)
//   once                     ... or ends after its first delivered datum (RTM.idl's once)
//   reader=latest|fifo[:N]|callback
//                            what the InPort must keep; the subscribe is refused when it keeps anything else
//                            (unset: whatever it keeps; `rtm cat` shows it)
//   depth=N                  data a subscription may fall behind by before the oldest are dropped (counted):
//                            its queue, pre-allocated (0: the port's OutPortOptions::queue_depth)
//   delivery=writer|thread   who makes a remote call: write() itself when the subscription is idle, or always
//                            its delivery thread (unset: the port's default, e.g. a runner's --delivery)
//   call=Nms                 bound on one remote call by the delivery thread (0: the port's
//                            OutPortOptions::call_timeout_ms)
//   path=auto|corba          auto: the fastest kind the peer speaks; corba: never shared memory
//
// Tokens are separated by spaces or commas, in any order; to_string() writes them back in the
// order above. Which kind of connection a subscription becomes (ConnKind) follows from the
// policy and from where the InPort is: it is shown beside the policy, not chosen by it.
#pragma once

#include "RTMExt.hh"

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace rtm {

// What a subscription is, chosen at subscribe:
//   in_process        an InPort of this process: filled by write() without an any, or by the
//                     subscription's thread when storing may wait or runs user code
//   shared_memory     an InPort of another process on this host: reads the port's ring in
//                     its own cycle, no call per datum
//   remote_by_writer  CORBA; write() makes the call while the subscription is idle
//   remote_by_thread  CORBA; the subscription's delivery thread makes every call
enum class ConnKind { in_process, shared_memory, remote_by_writer, remote_by_thread };
const char* to_string(ConnKind kind);

// What the InPort keeps (InPortPolicy's kinds); capacity 0: any FIFO capacity.
struct ReaderPolicy {
  enum class Kind { any, latest, fifo, callback };
  Kind kind = Kind::any;
  std::uint32_t capacity = 0;
  bool operator==(const ReaderPolicy&) const = default;
};

struct ConnPolicy {
  // The deepest queue a subscription may ask: each is pre-allocated, and a subscriber must not
  // make the publisher allocate without bound (256 KiB of TimedFloat6).
  static constexpr std::uint32_t kMaxDepth = 4096;
  enum class Delivery { port_default, writer_when_idle, thread };
  bool once = false;
  ReaderPolicy reader;
  std::uint32_t depth = 0;
  Delivery delivery = Delivery::port_default;
  std::uint32_t call_timeout_ms = 0;
  bool corba_only = false;
  bool operator==(const ConnPolicy&) const = default;

  static ConnPolicy repeated() { return {}; }
  static ConnPolicy one_shot() {
    ConnPolicy p;
    p.once = true;
    return p;
  }
};

// The text form above; fields at their defaults are not written ("repeated" alone for the default policy).
std::string to_string(const ConnPolicy& policy);
// Parses the text form; std::invalid_argument naming the token that is wrong and what it may
// be (an unknown key, a number out of range, a value twice). "" is the default policy.
// once_apart: once/repeated given beside the text (a system file's `type:`, `--once`, the
// API's "type"); it sets the lifetime, and contradicting the text is std::invalid_argument.
ConnPolicy parse_conn_policy(std::string_view text, std::optional<bool> once_apart = std::nullopt);
// "latest", "fifo:8", "callback" (what an InPort tells as its reader_policy).
std::string to_string(const ReaderPolicy& reader);
// The reverse of to_string(ReaderPolicy); std::invalid_argument for any other text.
ReaderPolicy parse_reader_policy(std::string_view text);
// Whether an InPort that keeps `kept` satisfies `wanted`.
bool satisfies(const ReaderPolicy& kept, const ReaderPolicy& wanted);

// To and from RTMExt.idl's ConnPolicy. from_idl throws std::invalid_argument on an enum value
// out of range or a depth above ConnPolicy::kMaxDepth (a peer of a newer build, or a hostile one).
RTM::ConnPolicy to_idl(const ConnPolicy& policy);
ConnPolicy from_idl(const RTM::ConnPolicy& policy);

}  // namespace rtm
