// SPDX-License-Identifier: Apache-2.0
// Writes a loop's log to a file without the loop ever calling write() or waiting on a lock:
// the loop appends text to one of two fixed buffers; a full one is handed to a writer thread
// (SCHED_OTHER), which writes it while the loop fills the other. When the writer is still busy
// with the last buffer as the next one fills (the disk stalled), appends are dropped, whole,
// and counted, never waited for. One appending thread.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

namespace rtm {

class BackgroundWriter {
 public:
  // Opens (truncates) `path`; throws std::runtime_error naming the path and the reason.
  // `buffer_bytes`: the size of each of the two buffers (at least 4 KiB).
  explicit BackgroundWriter(const std::string& path, std::size_t buffer_bytes = std::size_t{1} << 20);
  // flush(), then joins the writer and closes the file.
  ~BackgroundWriter();
  BackgroundWriter(const BackgroundWriter&) = delete;
  BackgroundWriter& operator=(const BackgroundWriter&) = delete;

  // The loop's side: copies `text` into the buffer being filled. Never blocks, never
  // allocates. False (and counted) when it was dropped: longer than a buffer, or no room
  // because the writer has not finished the previous buffer yet.
  bool append(std::string_view text);
  // Hands what was appended so far to the writer and waits until it is in the file (not for
  // the loop: at the end of a run, or in a test).
  void flush();

  std::uint64_t dropped() const { return dropped_.load(std::memory_order_relaxed); }
  // The first write error the writer met ("" while none): what it wrote after is lost.
  std::string error() const;

 private:
  bool hand_over();  // the loop's full buffer to the writer, if it is free (try_lock)
  void run();

  std::FILE* file_ = nullptr;
  std::string path_;
  std::size_t capacity_;
  std::vector<char> filling_;  // the loop's; size() is what was appended
  std::vector<char> pending_;  // handed over, not yet taken by the writer (empty: none)
  std::vector<char> writing_;  // the writer's
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::condition_variable written_;
  bool stop_ = false;
  std::uint64_t handed_ = 0, done_ = 0;  // buffers handed over / written (under mutex_)
  std::string error_;
  std::atomic<std::uint64_t> dropped_{0};
  std::thread writer_;
};

}  // namespace rtm
