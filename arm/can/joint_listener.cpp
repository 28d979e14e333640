// SPDX-License-Identifier: Apache-2.0
#include "arm/can/joint_listener.h"

#include <stdexcept>

namespace rtm::can {

namespace {

constexpr canid_t kExactId = CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG;

constexpr std::array<FrameFilter, kDriveCount + 1> kFilters = [] {
  std::array<FrameFilter, kDriveCount + 1> filters{};
  filters[0] = {cob::kSync, kExactId};
  for (int joint = 0; joint < kDriveCount; ++joint)
    filters[static_cast<std::size_t>(joint) + 1] = {cob::kTpdo1Base + drive_node(joint), kExactId};
  return filters;
}();

}  // namespace

std::span<const FrameFilter> JointListener::filters() { return kFilters; }

JointListener::JointListener(std::unique_ptr<Bus> bus) : bus_(std::move(bus)) {
  if (!bus_) throw std::invalid_argument("JointListener: no bus");
}

JointListener::JointListener(std::string_view bus_spec) : JointListener(open_bus(bus_spec, filters())) {}

JointListener::~JointListener() { stop(); }

void JointListener::start() {
  receiver_.start(
      *bus_, [this](const can_frame& frame, std::int64_t received_ns) { handle(frame, received_ns); },
      [this](const BusError& e) {
        std::lock_guard lock(mutex_);
        bus_error_ = std::string("joint listener: ") + e.what();
      });
}

void JointListener::stop() { receiver_.stop(); }

void JointListener::handle(const can_frame& frame, std::int64_t received_ns) {
  const Classified c = classify(frame);
  if (c.type != FrameType::sync && c.type != FrameType::drive_feedback) return;
  std::lock_guard lock(mutex_);
  if (c.type == FrameType::sync) {
    const auto sync = decode_sync(frame);
    if (!sync) { ++counters_.malformed_frames; return; }
    open_window(sync->counter, received_ns);
    return;
  }
  const auto feedback = decode_drive_feedback(frame);
  if (!feedback) { ++counters_.malformed_frames; return; }
  ++counters_.feedback_frames;
  if (counters_.syncs == 0) return;  // answers a SYNC this listener did not hear
  joints_.add(*feedback);
  if (!window_published_ && joints_.complete()) {
    ++counters_.complete_syncs;
    publish();
  }
}

// A SYNC closes the window of the one before: what came of it is published unless it was
// already, complete, when the last drive answered.
void JointListener::open_window(std::uint8_t sync_counter, std::int64_t received_ns) {
  if (!window_published_) {
    ++counters_.incomplete_syncs;
    publish();
  }
  ++counters_.syncs;
  window_sync_counter_ = sync_counter;
  window_sync_time_ns_ = received_ns;
  joints_.restart();
  window_published_ = false;
}

void JointListener::publish() {
  JointState& s = latest_;
  joints_.fill(s);
  s.sync_counter = window_sync_counter_;
  s.sync_time_ns = window_sync_time_ns_;
  s.cycle = counters_.syncs;
  window_published_ = true;
}

JointState JointListener::latest() const {
  std::lock_guard lock(mutex_);
  return latest_;
}

Fault JointListener::fault() const {
  std::lock_guard lock(mutex_);
  if (bus_error_.empty()) return {};
  return {FaultKind::bus_error, 0, 0, bus_error_};
}

FaultKind JointListener::fault_kind() const {
  std::lock_guard lock(mutex_);
  return bus_error_.empty() ? FaultKind::none : FaultKind::bus_error;
}

JointListenerCounters JointListener::counters() const {
  std::lock_guard lock(mutex_);
  return counters_;
}

}  // namespace rtm::can
