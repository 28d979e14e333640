// SPDX-License-Identifier: Apache-2.0
// A ring of data in shared memory that one writer fills and any number of readers, in any
// process that maps it, take from without a lock, a system call or a wake-up: the same-host
// path of ports. The writer never waits for a reader: it overwrites the oldest slot. Each slot
// carries a sequence number that is odd while the slot is written, so a reader never keeps a
// torn datum; a reader that fell more than a ring behind learns how many data it missed.
//
//   ShmRingWriter writer(memory, bytes, {.slots = 8, .payload_bytes = 48, .type_id = id});
//   writer.write(datum_bytes);                       // wait-free, no system call
//   ShmRingReader reader(memory, bytes, id);         // checks the layout the writer made
//   reader.take_latest(buffer);                      // a periodic reader: in its own cycle
//   reader.take_next(buffer);                        // a FIFO reader: oldest not yet taken
//   reader.wait_for_data(deadline_ns);               // an on-arrival reader: one futex wait
//
// A writer killed in the middle of a write leaves that slot odd and the published head on the
// last whole datum: readers keep getting that one. An on-arrival reader costs the writer one
// futex wake per datum while it waits (a reader killed while waiting leaves that cost behind
// until the segment is made again); periodic readers cost the writer nothing.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <span>

namespace rtm {

// ================================ layout ================================

// What the writer decides when it lays the ring out.
struct ShmRingShape {
  std::uint32_t slots = 8;           // data kept (>= 2: a reader always has a whole one)
  std::uint32_t payload_bytes = 64;  // largest datum, bytes
  std::uint64_t type_id = 0;         // what the data are; a reader expecting another refuses
};

// Bytes a ring of that shape needs (the size of the memory to give the writer).
std::size_t shm_ring_bytes(const ShmRingShape& shape);

// What a read found (as Orocos RTT's FlowStatus).
enum class ReadStatus {
  no_data,   // nothing written yet (or, for take_next, nothing newer than the last taken)
  old_data,  // take_latest: the datum taken last time, again
  new_data,  // a datum not taken before
};

struct RingRead {
  ReadStatus status = ReadStatus::no_data;
  std::size_t size = 0;        // bytes copied into the buffer
  std::uint64_t number = 0;    // the datum's number (1 for the first written)
  std::uint64_t missed = 0;    // take_next: data overwritten before this reader took them
};

namespace shm_detail {
struct RingHeader;
struct SlotHeader;
}  // namespace shm_detail

// ================================ writer ================================

// The one writer of a ring. Not thread-safe: one thread writes at a time (the OutPort writes it
// under its own lock).
class ShmRingWriter {
 public:
  // Lays a ring of that shape out in memory (bytes >= shm_ring_bytes(shape), 64-byte aligned,
  // zero-filled, e.g. a fresh shared mapping). Throws std::invalid_argument for a bad shape.
  ShmRingWriter(void* memory, std::size_t bytes, const ShmRingShape& shape);

  // Publishes a datum (size <= payload_bytes, else std::length_error, nothing published).
  // Wait-free; one futex wake when an on-arrival reader waits, else no system call.
  void write(std::span<const std::byte> datum);

  std::uint64_t written() const;  // data published so far
  const ShmRingShape& shape() const { return shape_; }

 private:
  shm_detail::RingHeader* header_;
  std::byte* slots_;
  ShmRingShape shape_;
  std::uint32_t slot_bytes_;
  std::uint64_t next_ = 1;
};

// ================================ reader ================================

// One reader of a ring; several may read one ring, each with its own ShmRingReader (one
// thread each). Never blocks the writer and never sees a torn datum.
class ShmRingReader {
 public:
  // Checks the layout in memory (a ring a writer made, of at most bytes) against what this
  // reader expects; throws std::runtime_error saying what differs. The reader starts after the
  // newest datum there: take_next() returns data written from now on.
  ShmRingReader(void* memory, std::size_t bytes, std::uint64_t expected_type_id);

  // The newest datum, copied into buffer (at least payload_bytes). new_data when it was not taken by this
  // reader before, old_data when it was (copied again), no_data before the first write. Wait-free in
  // practice: gives up (no_data) only after a writer lapped the ring 64 times during one read.
  RingRead take_latest(std::span<std::byte> buffer);

  // The oldest datum this reader has not taken yet (FIFO), with how many older ones it missed
  // because the writer overwrote them first. no_data when there is none newer.
  RingRead take_next(std::span<std::byte> buffer);

  // Waits until a datum newer than the last one this reader took (or saw at construction) is published: true
  // at once when there is one, else when a write wakes it; false when deadline_ns (CLOCK_MONOTONIC) passed
  // first. kNoDeadline waits however long it takes and saves arming a timer at each wait. cancel, when given,
  // is looked at after every wake-up: once true, the next interrupt() ends the wait (false); a write ends it
  // with true, as always.
  static constexpr std::int64_t kNoDeadline = INT64_MAX;
  bool wait_for_data(std::int64_t deadline_ns, const std::atomic<bool>* cancel = nullptr);
  // The same wait for a datum newer than `number`, touching nothing of this reader but the ring's own words:
  // another thread may take from this reader (under its owner's lock) while one waits here without it.
  bool wait_past(std::uint64_t number, std::int64_t deadline_ns, const std::atomic<bool>* cancel = nullptr) const;
  // Wakes every reader of this ring waiting in wait_for_data(), in any process: each looks at its cancel flag
  // and its data again (one spurious wake-up for those with nothing new). Set the flag first.
  void interrupt();

  // Number of the newest datum published (0: none). One load of the line the writer writes at every datum.
  std::uint64_t published() const;
  // Whether a datum newer than the last one this reader took (or saw at construction) is there. A reader
  // still behind the head its take_next() saw last answers from that and loads nothing shared: polling a
  // backlog does not pull the writer's head line away at every datum (a cache miss per write).
  bool has_new();
  // Skips all but the newest `keep` of the data not taken yet, of those behind the head that take_next() or
  // has_new() loaded last (it loads nothing); returns how many it skipped. A reader that keeps at most `keep`
  // calls it before it takes a backlog, so that it is never more than that behind what it last saw.
  std::uint64_t skip_older(std::uint64_t keep);
  // On-arrival readers in wait_for_data() now, in any process (a reader killed while waiting stays counted).
  std::uint32_t waiting() const;
  // True when the slot after the newest datum is half-written: the writer is in a write now,
  // or died in one (then it stays true).
  bool write_in_progress() const;
  const ShmRingShape& shape() const { return shape_; }
  // Number of the last datum this reader took (or skipped, or saw at construction).
  std::uint64_t last_taken() const { return last_taken_; }

 private:
  // Copies datum `number` from its slot; false when the slot does not hold it whole
  // (overwritten, or being written). Sets size on success.
  bool copy_datum(std::uint64_t number, std::span<std::byte> buffer, std::size_t& size) const;

  shm_detail::RingHeader* header_;
  std::byte* slots_;
  ShmRingShape shape_;
  std::uint32_t slot_bytes_;
  std::uint64_t last_taken_ = 0;  // number of the last datum taken (or seen at construction)
  std::uint64_t known_head_ = 0;  // the head take_next() or has_new() loaded last
};

}  // namespace rtm
