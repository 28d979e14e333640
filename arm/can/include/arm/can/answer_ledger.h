// SPDX-License-Identifier: Apache-2.0
// Which of our recent SYNCs one node still owes an answer to, so that an answer nobody asked for
// is seen: after each SYNC a drive sends one TPDO1 and a force sensor one TPDO1 and one TPDO2,
// in order. A frame on the node's COB-ID with no SYNC left to answer is one more than the node
// was asked for: another sender on the bus uses that id (a spoofed drive or sensor).
//
// An answer is matched to the newest SYNC still owed: a node that answers is taken to answer
// the SYNC just sent, and the older ones it still owes age out. SYNCs older than `expiry` SYNCs
// lapse, so a node that once missed answers (not yet operational, a lost frame) leaves no credit
// another sender could spend beyond `expiry` SYNCs later; and a responder that was stalled and
// then answers a backlog of SYNCs in one burst (the simulator on a loaded host) still finds
// them owed. Fixed size, no allocation.
#pragma once

#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>

namespace rtm::can {

class AnswerLedger {
 public:
  static constexpr int kMaxExpiry = 256;
  enum class Match : std::uint8_t {
    current,      // the answer to the last SYNC
    older,        // the last SYNC was answered: one before it, still within expiry (late)
    unsolicited,  // nothing was owed
  };

  explicit AnswerLedger(int expiry = 64) : expiry_(std::clamp(expiry, 1, kMaxExpiry)) {}

  // A SYNC was sent: one more answer is owed; the one owed `expiry` SYNCs ago lapses.
  void on_sync() {
    for (std::size_t w = kWords - 1; w > 0; --w) owed_[w] = (owed_[w] << 1) | (owed_[w - 1] >> 63);
    owed_[0] = (owed_[0] << 1) | 1u;
    // Bit i is the SYNC sent i SYNCs ago; only bits 0..expiry-1 are kept.
    for (std::size_t w = 0; w < kWords; ++w) {
      const int first = static_cast<int>(w) * 64;
      if (first >= expiry_) owed_[w] = 0;
      else if (expiry_ - first < 64) owed_[w] &= (std::uint64_t{1} << (expiry_ - first)) - 1;
    }
  }

  Match on_answer() {
    for (std::size_t w = 0; w < kWords; ++w) {
      if (owed_[w] == 0) continue;
      const int bit = std::countr_zero(owed_[w]);  // the newest SYNC still owed
      owed_[w] &= owed_[w] - 1;
      return (w == 0 && bit == 0) ? Match::current : Match::older;
    }
    return Match::unsolicited;
  }

  // Nothing is owed (nodes taken out of operational answer nothing).
  void clear() { owed_.fill(0); }
  int owed() const {
    int n = 0;
    for (std::uint64_t w : owed_) n += std::popcount(w);
    return n;
  }

 private:
  static constexpr std::size_t kWords = kMaxExpiry / 64;
  int expiry_;
  std::array<std::uint64_t, kWords> owed_{};
};

}  // namespace rtm::can
