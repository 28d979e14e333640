// SPDX-License-Identifier: Apache-2.0
// A value one thread publishes and a periodic cycle picks up, without a lock or an allocation
// on the cycle's side: a triple buffer.
//
//   LiveValue<std::array<float, 6>> gain{initial};
//   gain.publish(new_gain);                 // any thread (writers are serialised inside)
//   if (gain.take(gain_in_use)) { ... }     // the cycle: true when a new value came
//
// The reader always gets a whole value, the newest published, never a mix of two. A value
// published twice before the reader looks is taken once (the newer one).
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <mutex>
#include <type_traits>

namespace rtm {

template <class T>
  requires std::is_trivially_copyable_v<T>
class LiveValue {
 public:
  explicit LiveValue(const T& initial) : slots_{initial, initial, initial}, published_(initial) {}
  LiveValue(const LiveValue&) = delete;
  LiveValue& operator=(const LiveValue&) = delete;

  // Makes value the newest; the reader's next take() returns it.
  void publish(const T& value) {
    std::lock_guard lock(writer_mu_);
    published_ = value;
    slots_[back_] = value;
    back_ = middle_.exchange(static_cast<std::uint8_t>(back_ | kFresh), std::memory_order_acq_rel) & kIndex;
  }

  // The last value published (or the initial one). Writer side: takes the writers' lock.
  T published() const {
    std::lock_guard lock(writer_mu_);
    return published_;
  }

  // Reader (one thread): when a value was published since the last take(), copies it into
  // out and returns true; else leaves out alone. Wait-free.
  bool take(T& out) {
    if ((middle_.load(std::memory_order_acquire) & kFresh) == 0) return false;
    front_ = middle_.exchange(front_, std::memory_order_acq_rel) & kIndex;
    out = slots_[front_];
    return true;
  }

 private:
  static constexpr std::uint8_t kIndex = 0x3;
  static constexpr std::uint8_t kFresh = 0x4;
  std::array<T, 3> slots_;
  std::atomic<std::uint8_t> middle_{1};  // index of the slot between writer and reader, | kFresh
  std::uint8_t back_ = 2;                // the writer's slot (under writer_mu_)
  std::uint8_t front_ = 0;               // the reader's slot
  mutable std::mutex writer_mu_;
  T published_;
};

}  // namespace rtm
