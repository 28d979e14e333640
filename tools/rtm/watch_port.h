// SPDX-License-Identifier: Apache-2.0
// The temporary InPort `rtm watch` subscribes: takes every datum of the watched port's type
// into a bounded queue the display drains. Implements RTM::InPortEx so the publisher can name
// it ("rtm-watch-<pid>.in") and report how many data it dropped for it, and InPortOrdered so
// that what it shows is in the order written.
#pragma once

#include <RTM.hh>
#include <RTMExt.hh>

#include "rtm/sender_order.h"

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <string>
#include <vector>

namespace rtm::cli {

class WatchPort final : public virtual POA_RTM::InPortOrdered {
 public:
  WatchPort(std::string owner, CORBA::TypeCode_ptr type, std::size_t capacity);

  // RTM::InPort / RTM::InPortEx
  void put(const CORBA::Any& value) override;
  void push(const CORBA::Any& value) override;
  void put_in_order(const CORBA::Any& value, CORBA::ULongLong sender, CORBA::ULongLong seq) override;
  void push_in_order(const CORBA::Any& value, CORBA::ULongLong sender, CORBA::ULongLong seq) override;
  char* name() override;
  CORBA::TypeCode_ptr port_type() override;
  char* owner() override;
  RTM::PortCounters counters() override;
  char* last_error() override;
  RTM::PortDescription* describe() override;  // "rtm watch display", no elements
  void admit_writer() override {}              // the access screen (rtm/access.h) answers

  // Waits up to timeout for data; moves what arrived into out. Returns false on timeout.
  bool drain(std::vector<CORBA::Any>& out, std::chrono::milliseconds timeout);

  std::uint64_t received() const;
  std::uint64_t overflowed() const;  // lost here because the display fell behind
  std::uint64_t late() const;        // dropped: arrived after a later datum of its sender
  std::uint64_t rejected() const;    // wrong type

 private:
  void take(const CORBA::Any& value, const rtm::SenderSeq* order);  // put(), with the order check

  const std::string owner_;
  CORBA::TypeCode_var type_;
  const std::size_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable arrived_;
  std::deque<CORBA::Any> queue_;
  std::uint64_t received_ = 0, overflowed_ = 0, rejected_ = 0, late_ = 0;
  rtm::SenderOrder order_;
  std::string last_error_;
};

}  // namespace rtm::cli
