// SPDX-License-Identifier: Apache-2.0
// The order check behind RTM::InPortOrdered: remembers, per sender, the number of the last datum taken, for
// the few senders a port has at once (fixed storage, no allocation). Not thread-safe: the port calls it under
// the lock that also guards what it stores, so that the check and the store are one step.
#pragma once

#include <array>
#include <cstdint>

namespace rtm {

// A datum's place in its sender's stream, as RTM::InPortOrdered's calls carry it.
struct SenderSeq {
  std::uint64_t sender, seq;
};

class SenderOrder {
 public:
  static constexpr std::size_t kSenders = 8;

  // True when seq is above the last number taken from sender (or sender is new), and then remembers it; false
  // for a late datum. A sender not heard from for longest makes room for a new one when all slots are used.
  bool admit(std::uint64_t sender, std::uint64_t seq) {
    ++clock_;
    Slot* oldest = &slots_[0];
    for (Slot& slot : slots_) {
      if (slot.used != 0 && slot.sender == sender) {
        if (seq <= slot.last_seq) return false;
        slot.last_seq = seq;
        slot.used = clock_;
        return true;
      }
      if (slot.used < oldest->used) oldest = &slot;
    }
    *oldest = Slot{sender, seq, clock_};
    return true;
  }

 private:
  struct Slot {
    std::uint64_t sender = 0;
    std::uint64_t last_seq = 0;
    std::uint64_t used = 0;  // clock_ at the last datum taken; 0: free
  };
  std::array<Slot, kSenders> slots_{};
  std::uint64_t clock_ = 0;
};

}  // namespace rtm
