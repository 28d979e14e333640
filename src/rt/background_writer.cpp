// SPDX-License-Identifier: Apache-2.0
#include "rt/background_writer.h"

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <utility>

#include "rt/thread.h"

namespace rtm {

BackgroundWriter::BackgroundWriter(const std::string& path, std::size_t buffer_bytes)
    : path_(path), capacity_(buffer_bytes < 4096 ? 4096 : buffer_bytes) {
  file_ = std::fopen(path.c_str(), "w");
  if (!file_) throw std::runtime_error(path + ": " + std::strerror(errno));
  std::setvbuf(file_, nullptr, _IONBF, 0);  // the buffers here are the buffering
  for (auto* buffer : {&filling_, &pending_, &writing_}) buffer->reserve(capacity_);
  writer_ = std::thread([this] { run(); });
}

BackgroundWriter::~BackgroundWriter() {
  flush();
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  writer_.join();
  std::fclose(file_);
}

bool BackgroundWriter::append(std::string_view text) {
  if (text.size() > capacity_) {
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  if (filling_.size() + text.size() > capacity_ && !hand_over()) {
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  filling_.insert(filling_.end(), text.begin(), text.end());  // within the reserved capacity
  return true;
}

bool BackgroundWriter::hand_over() {
  std::unique_lock lock(mutex_, std::try_to_lock);
  if (!lock.owns_lock() || !pending_.empty()) return false;  // the writer has the last one still
  if (filling_.empty()) return true;
  std::swap(filling_, pending_);  // both keep their reserved capacity
  ++handed_;
  lock.unlock();
  wake_.notify_one();
  return true;
}

void BackgroundWriter::flush() {
  std::unique_lock lock(mutex_);
  written_.wait(lock, [this] { return pending_.empty(); });
  if (!filling_.empty()) {
    std::swap(filling_, pending_);
    ++handed_;
    wake_.notify_one();
  }
  const std::uint64_t target = handed_;
  written_.wait(lock, [&] { return done_ >= target; });
}

std::string BackgroundWriter::error() const {
  std::lock_guard lock(mutex_);
  return error_;
}

void BackgroundWriter::run() {
  set_thread_name("log-writer");
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return stop_ || !pending_.empty(); });
    if (pending_.empty()) return;  // stop_, nothing left
    std::swap(pending_, writing_);
    lock.unlock();
    written_.notify_all();  // pending_ is free again
    std::string failure;
    if (std::fwrite(writing_.data(), 1, writing_.size(), file_) != writing_.size())
      failure = path_ + ": write failed: " + std::strerror(errno);
    writing_.clear();
    lock.lock();
    if (!failure.empty() && error_.empty()) error_ = std::move(failure);
    ++done_;
    written_.notify_all();
  }
}

}  // namespace rtm
