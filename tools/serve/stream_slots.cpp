// SPDX-License-Identifier: Apache-2.0
#include "serve/stream_slots.h"

#include <fmt/format.h>

#include <algorithm>

namespace rtm::cli {

// What the slots share with the StreamSlots that made them (which may go first).
struct StreamSlots::Slot::Shared {
  explicit Shared(std::size_t n) : in_all(n) {}
  const std::size_t in_all;
  std::mutex mu;
  std::size_t open = 0;                                // slots not replaced
  std::map<std::pair<std::string, Kind>, Slot*> by_page;  // pages that named themselves
};

StreamSlots::Slot::Slot(std::shared_ptr<Shared> shared, std::string page, Kind kind)
    : shared_(std::move(shared)), page_(std::move(page)), kind_(kind) {}

StreamSlots::Slot::~Slot() {
  std::lock_guard lock(shared_->mu);
  if (replaced_.load()) return;  // its place went to the stream that replaced it
  --shared_->open;
  if (!page_.empty()) shared_->by_page.erase({page_, kind_});
}

StreamSlots::StreamSlots(std::size_t in_all) : shared_(std::make_shared<Slot::Shared>(in_all)) {}

std::shared_ptr<StreamSlots::Slot> StreamSlots::open(const std::string& page, Kind kind) {
  const bool well_formed = page.size() <= 64 && std::all_of(page.begin(), page.end(), [](char c) {
                             return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                                    c == '_' || c == '-';
                           });
  if (!well_formed) throw std::invalid_argument("page: 1 to 64 of A-Z a-z 0-9 _ -, the id a page makes for itself");
  Slot::Shared& s = *shared_;
  std::lock_guard lock(s.mu);
  Slot* earlier = nullptr;
  if (!page.empty())
    if (auto it = s.by_page.find({page, kind}); it != s.by_page.end()) earlier = it->second;
  if (!earlier && s.open >= s.in_all)
    throw StreamsFull(fmt::format("refused: {} streams are open, the most rtm serve keeps; close a page or one of "
                                  "its plots, or wait for a page that was closed to be noticed (a second)",
                                  s.in_all));
  std::shared_ptr<Slot> slot(new Slot(shared_, page, kind));
  if (earlier) {
    earlier->replaced_.store(true);  // its place passes to the new one: the count stays
  } else {
    ++s.open;
  }
  if (!page.empty()) s.by_page[{page, kind}] = slot.get();
  return slot;
}

std::size_t StreamSlots::open_count() const {
  std::lock_guard lock(shared_->mu);
  return shared_->open;
}

}  // namespace rtm::cli
