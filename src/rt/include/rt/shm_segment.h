// SPDX-License-Identifier: Apache-2.0
// Shared-memory segments of one user: files on a tmpfs in a folder only that user can enter,
// each mapped by the process that made it and by readers of the same user.
//
//   ShmSegment seg = ShmSegment::create(shm_ring_bytes(shape), "sensor0.out0");
//   ... hand seg.name() to a reader of this user (over the port's CORBA negotiation) ...
//   ShmSegment mine = ShmSegment::open(name);   // in the reader's process
//
// The folder is $XDG_RUNTIME_DIR/rtm-shm when XDG_RUNTIME_DIR is a tmpfs folder of this user, else
// /dev/shm/rtm-<uid>; it is made 0700 and refused when another user owns it, it is a link, or others may
// enter it. Segment files are 0600: another user can neither map one nor plant one where a reader would open
// it. A name carries the maker's pid and start time: create() first removes the segments of processes that no
// longer exist, so a killed process leaves nothing behind after the next start. Pages are faulted in at
// create and open: the periodic path touches no page for the first time.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>
#include <utility>

namespace rtm {

// A process's start time in clock ticks since boot (/proc/<pid>/stat, field 22); 0 when no
// such process exists. With the pid it names one process, even after the pid is reused.
unsigned long long process_start_ticks(long pid);

// Who can share memory with this process: the kernel's boot id and this process's network
// namespace ("<boot id>/net:<inode>"). Two processes with the same text run on one kernel and
// see one loopback; another host, or a network namespace standing in for one, differs.
std::string shm_host_identity();

class ShmSegment {
 public:
  // The folder of this user's segments (made when missing); std::runtime_error saying why it cannot be used.
  static std::filesystem::path folder();

  // A new zero-filled segment of bytes, 0600, named after label (characters outside [A-Za-z0-9._-] become
  // '_'), this process and a counter. Removes stale segments first. std::runtime_error with the reason.
  static ShmSegment create(std::size_t bytes, std::string_view label);

  // Maps the segment called name (a file name in folder(), no path) for reading and waiting. Refused
  // (std::runtime_error, saying why) unless it is a regular 0600 file of this user of at most 256 MiB.
  static ShmSegment open(std::string_view name);

  // Removes the segment files of processes that no longer exist from folder(); returns how
  // many. Files this user does not own are left alone.
  static int remove_stale();

  ShmSegment(ShmSegment&& other) noexcept;
  ShmSegment& operator=(ShmSegment&& other) noexcept;
  ShmSegment(const ShmSegment&) = delete;
  ShmSegment& operator=(const ShmSegment&) = delete;
  // Unmaps; the process that created the segment also removes its file (mappings of readers
  // stay valid until they unmap).
  ~ShmSegment();

  void* data() const { return data_; }
  std::size_t size() const { return size_; }
  const std::string& name() const { return name_; }
  bool owner() const { return owner_; }

 private:
  ShmSegment(void* data, std::size_t size, std::string name, bool owner)
      : data_(data), size_(size), name_(std::move(name)), owner_(owner) {}
  void release();

  void* data_ = nullptr;
  std::size_t size_ = 0;
  std::string name_;
  bool owner_ = false;
};

}  // namespace rtm
