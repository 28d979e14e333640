// SPDX-License-Identifier: Apache-2.0
// rtm serve's open streams (the system's and the plots'), counted: at most in_all at once, and
// one of each kind per page. A page names itself with an id it makes at random and sends with
// each stream; its new stream of a kind replaces its old one, which sees replaced() and ends
// (a page that was left without closing its streams holds no slot once it is back). A stream
// that names no page is one of its own. Beyond in_all a stream is refused (StreamsFull), so
// that open streams never take what the API needs.
#pragma once

#include <atomic>
#include <cstddef>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <utility>

namespace rtm::cli {

class StreamsFull : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class StreamSlots {
 public:
  enum class Kind { system, values };

  // One open stream's place; it is free again when the Slot is destroyed.
  class Slot {
   public:
    ~Slot();
    Slot(const Slot&) = delete;
    Slot& operator=(const Slot&) = delete;
    // The page opened another stream of this kind: this one should end.
    bool replaced() const { return replaced_.load(); }

   private:
    friend class StreamSlots;
    struct Shared;
    Slot(std::shared_ptr<Shared> shared, std::string page, Kind kind);
    std::shared_ptr<Shared> shared_;
    std::string page_;
    Kind kind_;
    std::atomic<bool> replaced_{false};
  };

  explicit StreamSlots(std::size_t in_all);

  // A slot for page's stream of this kind, replacing the page's earlier one. page: "" (none)
  // or 1 to 64 of A-Z a-z 0-9 _ -; std::invalid_argument otherwise. StreamsFull, with the
  // sentence the API answers, when in_all streams are open and none is replaced.
  std::shared_ptr<Slot> open(const std::string& page, Kind kind);
  // Streams holding a slot now (those replaced not counted).
  std::size_t open_count() const;

 private:
  std::shared_ptr<Slot::Shared> shared_;
};

}  // namespace rtm::cli
