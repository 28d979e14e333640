// SPDX-License-Identifier: Apache-2.0
#include "host/name_binding.h"

#include "rtm/log.h"

#include <fmt/format.h>

namespace rtm {

NameBinding::NameBinding(CORBA::ORB_ptr orb, NamingAddress address, ComponentPath path,
                         CORBA::Object_ptr object)
    : NameBinding(orb, std::move(address), std::move(path), object, Options{}) {}

NameBinding::NameBinding(CORBA::ORB_ptr orb, NamingAddress address, ComponentPath path,
                         CORBA::Object_ptr object, Options options)
    : client_(orb, std::move(address), options.call_timeout),
      path_(std::move(path)),
      object_(CORBA::Object::_duplicate(object)),
      options_(std::move(options)) {
  check_name(path_.name);
  if (path_.host.empty()) path_.host = local_host_name();
  check_once(true);
  watcher_ = std::thread([this] { watch(); });
}

NameBinding::~NameBinding() { unbind(); }

void NameBinding::log(bool is_error, const std::string& line) const {
  if (options_.log) {
    options_.log(is_error, line);
  } else if (is_error) {
    rtm::log().error("{}", line);
  } else {
    rtm::log().info("{}", line);
  }
}

void NameBinding::unbind() {
  bool was_bound = false;
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return;
    stopping_ = true;
    was_bound = bound_;
    bound_ = false;
  }
  wake_.notify_all();
  if (watcher_.joinable()) watcher_.join();
  if (!was_bound) return;
  try {
    if (!client_.is_bound(path_)) return;  // gone already, e.g. a restarted service
    // Another process may have taken the name since the last check: leave its binding alone.
    CORBA::Object_var current = client_.resolve_object(path_);
    if (!current->_is_equivalent(object_)) {
      log(false, fmt::format("{} names another object now; left bound", path_.to_string()));
      return;
    }
    client_.unbind(path_);
    log(false, fmt::format("unbound {} from {} at {}", path_.name, path_.to_string(),
                           client_.address().to_string()));
  } catch (const NamingError& ex) {
    log(true, fmt::format("could not unbind {}: {}", path_.to_string(), ex.what()));
  }
}

bool NameBinding::is_bound() const {
  std::lock_guard lock(mutex_);
  return bound_;
}

std::uint64_t NameBinding::bind_count() const {
  std::lock_guard lock(mutex_);
  return bind_count_;
}

void NameBinding::watch() {
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    wake_.wait_for(lock, options_.check_interval, [this] { return stopping_; });
    if (stopping_) break;
    lock.unlock();
    check_once(false);
    lock.lock();
  }
}

// Whether obj answers: a component that still runs holds its name. A stopped or hung process
// (TIMEOUT) counts as running: it is not ours to displace.
bool NameBinding::answers(CORBA::Object_ptr obj) const {
  omniORB::setClientCallTimeout(obj, static_cast<CORBA::ULong>(options_.call_timeout.count()));
  try {
    return !obj->_non_existent();
  } catch (const CORBA::TRANSIENT&) {
  } catch (const CORBA::COMM_FAILURE&) {
  } catch (const CORBA::OBJECT_NOT_EXIST&) {
  } catch (const CORBA::Exception&) {
    return true;  // something answered, if only with an error
  }
  return false;
}

NameBinding::Found NameBinding::look() const {
  CORBA::Object_var current;
  try {
    current = client_.resolve_object(path_);
  } catch (const NamingError&) {
    if (!client_.is_bound(path_)) return Found::missing;
    throw;
  }
  if (current->_is_equivalent(object_)) return Found::ours;
  return answers(current.in()) ? Found::running_other : Found::stale;
}

// One look at the naming service; no lock is held across the remote calls. The name is bound
// when it is free, ours, or held by a component that no longer answers; never over one that
// runs (at the first look that is an error the constructor throws: two components of one
// name would otherwise take the name from each other at every check).
void NameBinding::check_once(bool first) {
  bool was_bound = false;
  {
    std::lock_guard lock(mutex_);
    was_bound = bound_;
  }
  try {
    const Found found = look();
    if (found == Found::running_other) {
      const std::string line = fmt::format("{} in naming service at {} names another component, which answers",
                                           path_.to_string(), client_.address().to_string());
      if (first) throw NameTaken(line + ": refusing to take its name (stop it, or choose another --name)");
      std::lock_guard lock(mutex_);
      if (!reported_taken_) {
        reported_taken_ = true;
        log(true, line + "; not re-binding while it runs");
      }
      bound_ = false;
      return;
    }
    if (found == Found::ours && was_bound) {
      std::lock_guard lock(mutex_);
      reported_unreachable_ = false;
      return;
    }
    // Missing, stale, or ours again after an outage or a restart: (re-)bind.
    client_.bind(path_, object_);
    std::lock_guard lock(mutex_);
    bound_ = true;
    reported_unreachable_ = false;
    reported_taken_ = false;
    ++bind_count_;
    log(false, fmt::format("{} {} at {} via {}{}", bind_count_ == 1 ? "bound" : "re-bound", path_.name,
                           path_.to_string(), client_.address().to_string(),
                           found == Found::stale ? " (in place of a component that no longer answers)" : ""));
  } catch (const NameTaken&) {
    throw;
  } catch (const NamingError& ex) {
    std::lock_guard lock(mutex_);
    bound_ = false;
    if (!reported_unreachable_) {
      reported_unreachable_ = true;
      log(true, fmt::format("{}; {} will bind when it appears", ex.what(), path_.name));
    }
  }
}

}  // namespace rtm
