// SPDX-License-Identifier: Apache-2.0
// A component's cycles as data, for re-simulation (docs/recording.md, "Re-simulation").
//
// A tap sits in a port's read() and write(). Logging, it keeps a copy of what each read gave
// and each write wrote in slots made at attach time, and tells a TapSink (the cycle log's
// writer, host/cycle_log.h) which slots to write out; the cycle thread allocates nothing, takes
// no lock and does no I/O for it. Replaying, the tap answers each read with what the log says it
// gave, in the same order, and keeps what each write wrote, so that a component's logic runs on
// logical time against yesterday's inputs and its outputs can be compared byte for byte.
//
// A port without a tap pays one pointer test per read and write. Taps are attached and detached
// while the component does not cycle (before on(), after off()).
#pragma once

#include "rtm/cdr.h"
#include "rtm/data.h"
#include "rtm/read_result.h"
#include "rt/schedule.h"

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace rtm {

// What a tap tells its sink. `count` values are in consecutive slots from `slot` (mod the
// tap's capacity): a read's one when its result is NewData (else none), a read_many's count, a
// write's one; `lost`: that many found no room and were not kept.
enum class TapEvent : std::uint8_t { read, read_many, write, lost };

// The log's side, called on the cycle thread: it must not block, allocate or do I/O.
class TapSink {
 public:
  virtual ~TapSink() = default;
  virtual void tapped(std::uint16_t port, TapEvent event, ReadResult result, std::uint32_t slot,
                      std::uint32_t count) noexcept = 0;
};

// Told by a ComponentServant (observe_cycles()) when the component starts, before each cycle,
// and when it stops; on the thread that runs them.
class CycleObserver {
 public:
  virtual ~CycleObserver() = default;
  virtual void starting() noexcept = 0;
  virtual void cycle(const CycleContext& ctx) noexcept = 0;
  virtual void stopping() noexcept = 0;
};

// The type-independent face of a port's tap, for the log's writer thread and for a replay.
class PortTap {
 public:
  virtual ~PortTap() = default;
  virtual CORBA::TypeCode_ptr type_code() const = 0;

  // ---- logging (the log's writer thread) ----
  // The value in `slot` as encapsulated CDR (rtm/cdr.h).
  virtual void encode(std::uint32_t slot, std::vector<std::uint8_t>& out) const = 0;
  // The oldest `count` slots are written out: the cycle thread may use them again.
  virtual void release(std::uint32_t count) noexcept = 0;

  // ---- replaying ----
  // The answer to the next read() (value: CDR of a NewData datum, else empty), or to the next
  // read_many() (each value's CDR). Throws std::invalid_argument for bytes not of the type.
  virtual void answer_read(ReadResult result, std::span<const std::uint8_t> value) = 0;
  virtual void answer_read_many(const std::vector<std::span<const std::uint8_t>>& values) = 0;
  // Reads the component made for which the log had no answer (it read more than it did then;
  // each was answered NoData), and answers left unread (it read less). Reset by clear().
  virtual std::size_t unanswered() const = 0;
  virtual std::size_t unused_answers() const = 0;
  // What write() wrote since the last call, each as CDR.
  virtual std::vector<std::vector<std::uint8_t>> take_written() = 0;
  virtual void clear() = 0;
};

// A port's tap of T. Logging: `capacity` slots of T, made here; a read or write that finds
// them all still waiting for the writer thread is not kept and tells the sink `lost`.
template <PortData T>
class TypedTap final : public PortTap {
 public:
  // A log's tap.
  TypedTap(TapSink& sink, std::uint16_t port, std::uint32_t capacity)
      : sink_(&sink), port_(port), slots_(capacity) {}
  // A replay's tap.
  TypedTap() = default;

  bool replaying() const { return sink_ == nullptr; }

  // ---- the port's side ----
  void logged_read(ReadResult result, const T& value) noexcept {
    if (result == ReadResult::NewData) keep(TapEvent::read, std::span(&value, 1));
    else sink_->tapped(port_, TapEvent::read, result, 0, 0);
  }
  void logged_read_many(std::span<const T> values) noexcept { keep(TapEvent::read_many, values); }
  void logged_write(const T& value) noexcept { keep(TapEvent::write, std::span(&value, 1)); }
  ReadResult replay_read(T& out) {
    if (answers_.empty() || answers_.front().many) {
      ++unanswered_;
      return ReadResult::NoData;
    }
    Answer& a = answers_.front();
    const ReadResult result = a.result;
    if (result == ReadResult::NewData) last_ = a.values.front();
    if (result != ReadResult::NoData) out = last_;
    answers_.pop_front();
    return result;
  }
  std::size_t replay_read_many(std::span<T> out) {
    if (answers_.empty() || !answers_.front().many) {
      ++unanswered_;
      return 0;
    }
    Answer& a = answers_.front();
    const std::size_t n = std::min(a.values.size(), out.size());
    for (std::size_t i = 0; i < n; ++i) out[i] = a.values[i];
    if (n > 0) last_ = a.values[n - 1];
    answers_.pop_front();
    return n;
  }
  void replay_write(const T& value) {
    CORBA::Any any;
    DataTraits<T>::insert(any, value);
    written_.push_back(to_cdr(any));
  }

  // ---- PortTap ----
  CORBA::TypeCode_ptr type_code() const override { return DataTraits<T>::type_code(); }
  void encode(std::uint32_t slot, std::vector<std::uint8_t>& out) const override {
    CORBA::Any any;
    DataTraits<T>::insert(any, slots_[slot % slots_.size()]);
    to_cdr(any, out);
  }
  void release(std::uint32_t count) noexcept override { tail_.fetch_add(count, std::memory_order_release); }
  void answer_read(ReadResult result, std::span<const std::uint8_t> value) override {
    Answer a{result, false, {}};
    if (result == ReadResult::NewData) a.values.push_back(decode(value));
    answers_.push_back(std::move(a));
  }
  void answer_read_many(const std::vector<std::span<const std::uint8_t>>& values) override {
    Answer a{ReadResult::NewData, true, {}};
    for (const auto& v : values) a.values.push_back(decode(v));
    answers_.push_back(std::move(a));
  }
  std::size_t unanswered() const override { return unanswered_; }
  std::size_t unused_answers() const override { return answers_.size(); }
  std::vector<std::vector<std::uint8_t>> take_written() override { return std::exchange(written_, {}); }
  void clear() override {
    answers_.clear();
    written_.clear();
    unanswered_ = 0;
  }

 private:
  struct Answer {
    ReadResult result;
    bool many;
    std::vector<T> values;
  };
  static T decode(std::span<const std::uint8_t> bytes) {
    const CORBA::Any any = from_cdr(DataTraits<T>::type_code(), bytes);
    const T* value = nullptr;
    if (!DataTraits<T>::extract(any, value) || value == nullptr)
      throw std::invalid_argument(std::string("a logged datum is not of type ") + std::string(DataTraits<T>::name));
    return *value;
  }
  // Copies values into consecutive slots from the cycle thread's head and tells the sink; or,
  // with no room for them all, tells it `lost`.
  void keep(TapEvent event, std::span<const T> values) noexcept {
    const auto n = static_cast<std::uint32_t>(values.size());
    if (n > slots_.size() || head_ + n - tail_.load(std::memory_order_acquire) > slots_.size()) {
      sink_->tapped(port_, TapEvent::lost, ReadResult::NoData, 0, n);
      return;
    }
    const auto slot = static_cast<std::uint32_t>(head_ % slots_.size());
    for (std::uint32_t i = 0; i < n; ++i) slots_[(slot + i) % slots_.size()] = values[i];
    head_ += n;
    sink_->tapped(port_, event, ReadResult::NewData, slot, n);
  }

  TapSink* sink_ = nullptr;
  std::uint16_t port_ = 0;
  std::vector<T> slots_;
  std::uint64_t head_ = 0;             // the cycle thread's: slots handed out
  std::atomic<std::uint64_t> tail_{0};  // the writer's: slots written out
  std::deque<Answer> answers_;
  std::vector<std::vector<std::uint8_t>> written_;
  std::size_t unanswered_ = 0;
  T last_{};
};

// A port's tap(): a log's tap (sink given) or a replay's, kept in `held` for the port's use.
template <PortData T>
std::unique_ptr<PortTap> make_tap(TapSink* sink, std::uint16_t key, std::uint32_t capacity, TypedTap<T>*& held) {
  auto tap = sink != nullptr ? std::make_unique<TypedTap<T>>(*sink, key, capacity) : std::make_unique<TypedTap<T>>();
  held = tap.get();
  return tap;
}

}  // namespace rtm
