// SPDX-License-Identifier: Apache-2.0
// The runner's hold on a component's name: bound while the component lives, bound again when
// the naming service restarts.
#pragma once

#include "rtm/naming.h"

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

namespace rtm {

// Binds a component for as long as it lives. The first bind is attempted in the constructor;
// if the naming service is unreachable, one error line is logged and the component carries on
// unbound; if the name is bound to another component that still answers, the constructor
// throws NameTaken (one name, one component); a binding whose component no longer answers is
// taken over. A background thread checks every check_interval that the binding is still there
// and re-binds when the service restarted (entry missing, or service back after an outage),
// never over another component that answers (it logs that once and waits).
// The destructor stops the thread and unbinds. No hot path is involved: the thread only
// sleeps and talks to the naming service.
class NameBinding {
 public:
  struct Options {
    std::chrono::milliseconds check_interval{500};
    std::chrono::milliseconds call_timeout = NamingClient::kDefaultCallTimeout;
    // Receives each bound/lost/error line; default: the "rtm" logger (rtm/log.h).
    std::function<void(bool is_error, const std::string& line)> log;
  };

  NameBinding(CORBA::ORB_ptr orb, NamingAddress address, ComponentPath path,
              CORBA::Object_ptr object, Options options);
  NameBinding(CORBA::ORB_ptr orb, NamingAddress address, ComponentPath path,
              CORBA::Object_ptr object);
  ~NameBinding();
  NameBinding(const NameBinding&) = delete;
  NameBinding& operator=(const NameBinding&) = delete;

  // Stops re-binding and removes the binding now (what the destructor does); idempotent.
  void unbind();
  // Whether the last check found the binding in place.
  bool is_bound() const;
  // How many times the name was bound (1 after a successful start, +1 per re-bind).
  std::uint64_t bind_count() const;
  const ComponentPath& path() const { return path_; }
  const NamingAddress& address() const { return client_.address(); }

 private:
  enum class Found { missing, ours, running_other, stale };
  void watch();
  void check_once(bool first);
  Found look() const;
  bool answers(CORBA::Object_ptr obj) const;
  void log(bool is_error, const std::string& line) const;

  NamingClient client_;
  ComponentPath path_;
  CORBA::Object_var object_;
  Options options_;

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  bool bound_ = false;
  bool reported_unreachable_ = false;
  bool reported_taken_ = false;
  std::uint64_t bind_count_ = 0;
  std::thread watcher_;
};

}  // namespace rtm
