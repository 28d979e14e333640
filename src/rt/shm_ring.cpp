// SPDX-License-Identifier: Apache-2.0
#include "rt/shm_ring.h"

#include <linux/futex.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <cstring>
#include <ctime>
#include <limits>
#include <new>
#include <stdexcept>
#include <string>

namespace rtm {

namespace shm_detail {

// "RTMRING1", little-endian. Stored last (release) by the writer: a reader that sees it sees all the layout.
constexpr std::uint64_t kMagic = 0x31474E49524D5452ULL;
constexpr std::uint32_t kVersion = 1;
constexpr std::uint32_t kMaxPayloadBytes = 1U << 26;  // 64 MiB: a larger datum is not a port's
constexpr std::uint32_t kMaxSlots = 1U << 16;

// The first 192 bytes of a ring. The layout fields are written once, before the magic.
struct alignas(64) RingHeader {
  std::uint64_t magic;
  std::uint32_t version;
  std::uint32_t slots;
  std::uint32_t payload_bytes;
  std::uint32_t slot_bytes;
  std::uint64_t type_id;
  std::uint64_t total_bytes;
  alignas(64) std::atomic<std::uint64_t> head;  // number of the newest whole datum; 0: none
  alignas(64) std::atomic<std::uint32_t> wake;  // futex word: bumped when a waiter must wake
  std::atomic<std::uint32_t> waiters;           // on-arrival readers in wait_for_data()
};

// Each slot: this header, then the payload as 64-bit words. Datum n lives in slot n % slots.
struct alignas(64) SlotHeader {
  std::atomic<std::uint64_t> seq;     // odd while the slot is written
  std::atomic<std::uint64_t> number;  // which datum the slot holds
  std::atomic<std::uint64_t> size;    // its bytes
};

static_assert(std::atomic<std::uint64_t>::is_always_lock_free, "a shared ring needs lock-free 64-bit atomics");
static_assert(std::atomic<std::uint32_t>::is_always_lock_free);

}  // namespace shm_detail

namespace {

using shm_detail::RingHeader;
using shm_detail::SlotHeader;

constexpr std::size_t round_up(std::size_t n, std::size_t to) { return (n + to - 1) / to * to; }

std::uint32_t slot_bytes_for(std::uint32_t payload_bytes) {
  return static_cast<std::uint32_t>(sizeof(SlotHeader) + round_up(payload_bytes, 64));
}

SlotHeader* slot_at(std::byte* slots, std::uint32_t slot_bytes, std::uint32_t count, std::uint64_t number) {
  return reinterpret_cast<SlotHeader*>(slots + (number % count) * slot_bytes);
}

std::uint64_t* payload_of(SlotHeader* slot) { return reinterpret_cast<std::uint64_t*>(slot + 1); }

long futex(std::atomic<std::uint32_t>* word, int op, std::uint32_t value, const timespec* timeout) {
  // Not FUTEX_PRIVATE_FLAG: the word is shared between processes.
  return syscall(SYS_futex, reinterpret_cast<std::uint32_t*>(word), op, value, timeout, nullptr,
                 FUTEX_BITSET_MATCH_ANY);
}

}  // namespace

std::size_t shm_ring_bytes(const ShmRingShape& shape) {
  return sizeof(RingHeader) + std::size_t{shape.slots} * slot_bytes_for(shape.payload_bytes);
}

// ================================ writer ================================

ShmRingWriter::ShmRingWriter(void* memory, std::size_t bytes, const ShmRingShape& shape)
    : shape_(shape), slot_bytes_(slot_bytes_for(shape.payload_bytes)) {
  if (shape.slots < 2 || shape.slots > shm_detail::kMaxSlots)
    throw std::invalid_argument("a shared ring needs 2 to 65536 slots, not " + std::to_string(shape.slots));
  if (shape.payload_bytes == 0 || shape.payload_bytes > shm_detail::kMaxPayloadBytes)
    throw std::invalid_argument("a shared ring's datum must be 1 byte to 64 MiB, not " +
                                std::to_string(shape.payload_bytes));
  if (reinterpret_cast<std::uintptr_t>(memory) % 64 != 0)
    throw std::invalid_argument("a shared ring's memory must be 64-byte aligned");
  const std::size_t needed = shm_ring_bytes(shape);
  if (bytes < needed)
    throw std::invalid_argument("a shared ring of that shape needs " + std::to_string(needed) +
                                " bytes, not " + std::to_string(bytes));
  header_ = new (memory) RingHeader{};
  header_->version = shm_detail::kVersion;
  header_->slots = shape.slots;
  header_->payload_bytes = shape.payload_bytes;
  header_->slot_bytes = slot_bytes_;
  header_->type_id = shape.type_id;
  header_->total_bytes = needed;
  slots_ = static_cast<std::byte*>(memory) + sizeof(RingHeader);
  for (std::uint32_t i = 0; i < shape.slots; ++i) new (slots_ + std::size_t{i} * slot_bytes_) SlotHeader{};
  std::atomic_ref<std::uint64_t>(header_->magic).store(shm_detail::kMagic, std::memory_order_release);
}

void ShmRingWriter::write(std::span<const std::byte> datum) {
  if (datum.size() > shape_.payload_bytes)
    throw std::length_error("a datum of " + std::to_string(datum.size()) + " bytes does not fit a ring of " +
                            std::to_string(shape_.payload_bytes) + "-byte slots");
  SlotHeader* slot = slot_at(slots_, slot_bytes_, shape_.slots, next_);
  const std::uint64_t seq = slot->seq.load(std::memory_order_relaxed) | 1U;  // odd: being written
  slot->seq.store(seq, std::memory_order_relaxed);
  // Every store below is a release (a plain store on x86): a reader that loads (acquire) any
  // of them afterwards also sees the odd sequence above, so its check after the copy fails.
  // (The same as a release fence here, which ThreadSanitizer does not model.)
  slot->number.store(next_, std::memory_order_release);
  slot->size.store(datum.size(), std::memory_order_release);
  // Word by word through atomics: a reader may be copying the slot at the same time (it then
  // sees the sequence change and drops its copy), and that must not be a data race.
  std::uint64_t* words = payload_of(slot);
  const std::size_t whole = datum.size() / 8;
  for (std::size_t i = 0; i < whole; ++i) {
    std::uint64_t w;
    std::memcpy(&w, datum.data() + i * 8, 8);
    std::atomic_ref<std::uint64_t>(words[i]).store(w, std::memory_order_release);
  }
  if (const std::size_t rest = datum.size() % 8; rest != 0) {
    std::uint64_t w = 0;
    std::memcpy(&w, datum.data() + whole * 8, rest);
    std::atomic_ref<std::uint64_t>(words[whole]).store(w, std::memory_order_release);
  }
  slot->seq.store(seq + 1, std::memory_order_release);
  // seq_cst, paired with the waiter's increment of waiters: either the writer sees the waiter
  // and wakes it, or the waiter sees this head and does not sleep.
  header_->head.store(next_, std::memory_order_seq_cst);
  ++next_;
  if (header_->waiters.load(std::memory_order_seq_cst) != 0) {
    header_->wake.fetch_add(1, std::memory_order_seq_cst);
    futex(&header_->wake, FUTEX_WAKE, INT_MAX, nullptr);
  }
}

std::uint64_t ShmRingWriter::written() const { return next_ - 1; }

// ================================ reader ================================

ShmRingReader::ShmRingReader(void* memory, std::size_t bytes, std::uint64_t expected_type_id) {
  if (bytes < sizeof(RingHeader) || reinterpret_cast<std::uintptr_t>(memory) % 64 != 0)
    throw std::runtime_error("not a shared ring: " + std::to_string(bytes) + " bytes");
  header_ = static_cast<RingHeader*>(memory);
  if (std::atomic_ref<std::uint64_t>(header_->magic).load(std::memory_order_acquire) != shm_detail::kMagic)
    throw std::runtime_error("not a shared ring (no RTM ring header)");
  if (header_->version != shm_detail::kVersion)
    throw std::runtime_error("a shared ring of layout version " + std::to_string(header_->version) +
                             "; this program reads version " + std::to_string(shm_detail::kVersion));
  shape_ = {header_->slots, header_->payload_bytes, header_->type_id};
  slot_bytes_ = header_->slot_bytes;
  // The layout is checked against the memory actually there: a bad header must not make the
  // reader copy from beyond the mapping.
  if (shape_.slots < 2 || shape_.slots > shm_detail::kMaxSlots || shape_.payload_bytes == 0 ||
      shape_.payload_bytes > shm_detail::kMaxPayloadBytes || slot_bytes_ != slot_bytes_for(shape_.payload_bytes) ||
      header_->total_bytes != shm_ring_bytes(shape_) || header_->total_bytes > bytes)
    throw std::runtime_error("a shared ring whose layout does not fit its " + std::to_string(bytes) + " bytes");
  if (shape_.type_id != expected_type_id)
    throw std::runtime_error("the shared ring carries another data type (type id " +
                             std::to_string(shape_.type_id) + ", expected " + std::to_string(expected_type_id) + ")");
  slots_ = static_cast<std::byte*>(memory) + sizeof(RingHeader);
  last_taken_ = header_->head.load(std::memory_order_acquire);
  known_head_ = last_taken_;
}

bool ShmRingReader::copy_datum(std::uint64_t number, std::span<std::byte> buffer, std::size_t& size) const {
  SlotHeader* slot = slot_at(slots_, slot_bytes_, shape_.slots, number);
  const std::uint64_t before = slot->seq.load(std::memory_order_acquire);
  // Acquire loads, paired with the writer's release stores: the sequence check below then sees
  // any write that a loaded value came from (no fence, which ThreadSanitizer does not model).
  if ((before & 1U) != 0 || slot->number.load(std::memory_order_acquire) != number) return false;
  const std::uint64_t bytes = slot->size.load(std::memory_order_acquire);
  if (bytes > shape_.payload_bytes || bytes > buffer.size()) return false;
  const std::uint64_t* words = payload_of(slot);
  const std::size_t count = (bytes + 7) / 8;
  for (std::size_t i = 0; i < count; ++i) {
    const std::uint64_t w =
        std::atomic_ref<std::uint64_t>(const_cast<std::uint64_t&>(words[i])).load(std::memory_order_acquire);
    std::memcpy(buffer.data() + i * 8, &w, std::min<std::size_t>(8, bytes - i * 8));
  }
  if (slot->seq.load(std::memory_order_relaxed) != before) return false;  // written meanwhile: torn
  size = bytes;
  return true;
}

RingRead ShmRingReader::take_latest(std::span<std::byte> buffer) {
  for (int attempt = 0; attempt < 64; ++attempt) {
    const std::uint64_t head = header_->head.load(std::memory_order_acquire);
    if (head == 0) return {};
    RingRead result;
    if (!copy_datum(head, buffer, result.size)) continue;  // lapped during the copy: the newer one
    result.number = head;
    result.status = head == last_taken_ ? ReadStatus::old_data : ReadStatus::new_data;
    if (head > last_taken_) last_taken_ = head;
    return result;
  }
  return {};
}

RingRead ShmRingReader::take_next(std::span<std::byte> buffer) {
  RingRead result;
  bool reload = false;
  for (int attempt = 0; attempt < 64; ++attempt) {
    // While this reader is behind the head it saw last, that head is enough: the slot's own
    // sequence number says whether the datum is still there. The head, a line the writer
    // writes at every datum, is loaded again only once caught up with it or when a slot no
    // longer held the datum: a reader taking a backlog pays one such load, not one per datum.
    if (reload || known_head_ <= last_taken_) known_head_ = header_->head.load(std::memory_order_acquire);
    const std::uint64_t head = known_head_;
    if (head <= last_taken_) return result;  // no_data (missed may count skipped ones)
    std::uint64_t want = last_taken_ + 1;
    // The slot of head - slots + 1 is the one the writer fills next: skip it too.
    const std::uint64_t oldest = head + 2 > shape_.slots ? head + 2 - shape_.slots : 1;
    if (want < oldest) {
      result.missed += oldest - want;
      want = oldest;
      last_taken_ = want - 1;
    }
    if (!copy_datum(want, buffer, result.size)) {  // overwritten meanwhile: look again
      reload = true;
      continue;
    }
    last_taken_ = want;
    result.number = want;
    result.status = ReadStatus::new_data;
    return result;
  }
  return result;
}

bool ShmRingReader::wait_for_data(std::int64_t deadline_ns, const std::atomic<bool>* cancel) {
  return wait_past(last_taken_, deadline_ns, cancel);
}

bool ShmRingReader::wait_past(std::uint64_t number, std::int64_t deadline_ns, const std::atomic<bool>* cancel) const {
  const timespec deadline{static_cast<time_t>(deadline_ns / 1'000'000'000), static_cast<long>(deadline_ns % 1'000'000'000)};
  const bool forever = deadline_ns == std::numeric_limits<std::int64_t>::max();
  header_->waiters.fetch_add(1, std::memory_order_seq_cst);
  bool ready = false;
  for (;;) {
    const std::uint32_t seen = header_->wake.load(std::memory_order_seq_cst);
    if (header_->head.load(std::memory_order_seq_cst) > number) {
      ready = true;
      break;
    }
    // After loading `seen`: an interrupt() that set the flag before it is seen here, one after
    // it changes the word and the wait below returns at once.
    if (cancel != nullptr && cancel->load(std::memory_order_seq_cst)) break;
    // FUTEX_WAIT_BITSET takes an absolute CLOCK_MONOTONIC deadline; EAGAIN: woken meanwhile.
    // No deadline: no timer to arm and cancel at every wait (each costs a VM exit here).
    if (futex(&header_->wake, FUTEX_WAIT_BITSET, seen, forever ? nullptr : &deadline) != 0 && errno == ETIMEDOUT)
      break;
  }
  header_->waiters.fetch_sub(1, std::memory_order_seq_cst);
  return ready;
}

void ShmRingReader::interrupt() {
  header_->wake.fetch_add(1, std::memory_order_seq_cst);
  futex(&header_->wake, FUTEX_WAKE, INT_MAX, nullptr);
}

std::uint64_t ShmRingReader::published() const { return header_->head.load(std::memory_order_acquire); }

bool ShmRingReader::has_new() {
  if (known_head_ > last_taken_) return true;
  known_head_ = header_->head.load(std::memory_order_acquire);
  return known_head_ > last_taken_;
}

std::uint64_t ShmRingReader::skip_older(std::uint64_t keep) {
  if (known_head_ <= last_taken_ + keep) return 0;
  const std::uint64_t skipped = known_head_ - keep - last_taken_;
  last_taken_ = known_head_ - keep;
  return skipped;
}

std::uint32_t ShmRingReader::waiting() const { return header_->waiters.load(std::memory_order_acquire); }

bool ShmRingReader::write_in_progress() const {
  const std::uint64_t head = published();
  return (slot_at(slots_, slot_bytes_, shape_.slots, head + 1)->seq.load(std::memory_order_acquire) & 1U) != 0;
}

}  // namespace rtm
