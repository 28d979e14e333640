// SPDX-License-Identifier: Apache-2.0
#include "arm/can/sensor_listener.h"

#include "rt/clock.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <stdexcept>

namespace rtm::can {

SensorListener::SensorListener(std::unique_ptr<Bus> bus, std::uint8_t node, std::int64_t heartbeat_timeout_ns,
                               const rtm::Clock& clock)
    : bus_(std::move(bus)), node_(node), heartbeat_timeout_ns_(heartbeat_timeout_ns), clock_(clock) {
  if (!bus_) throw std::invalid_argument("SensorListener: no bus");
  if (!is_sensor_node(node)) {
    throw std::invalid_argument("SensorListener: " + node_description(node) +
                                " is not a force sensor node (0x10 wrist, 0x11 joystick)");
  }
}

namespace {

// What handle() reads: SYNC and the sensor node's own frames (TPDOs, heartbeat, EMCY: any
// function code, that node id, standard frames only). The bus (the kernel, or the local hub)
// then neither copies the listener the rest of the bus's traffic nor wakes it for it.
std::array<FrameFilter, 2> sensor_filters(std::uint8_t node) {
  constexpr canid_t kExactId = CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG;
  constexpr canid_t kNodeId = 0x7f | CAN_EFF_FLAG | CAN_RTR_FLAG;  // the node-id bits of a COB-ID
  return {{{cob::kSync, kExactId}, {node, kNodeId}}};
}

}  // namespace

SensorListener::SensorListener(std::string_view bus_spec, ForceSensor sensor, std::int64_t heartbeat_timeout_ns,
                               const rtm::Clock& clock)
    : SensorListener(open_bus(bus_spec, sensor_filters(sensor_node(sensor))), sensor_node(sensor),
                     heartbeat_timeout_ns, clock) {}

SensorListener::~SensorListener() { stop(); }

void SensorListener::handle(const can_frame& frame, std::int64_t received_ns) {
  const Classified c = classify(frame);
  if (c.type != FrameType::sync && c.node != node_) return;  // another node's traffic
  std::lock_guard lock(mutex_);
  switch (c.type) {
    case FrameType::sync: {
      const auto sync = decode_sync(frame);
      if (!sync) { ++counters_.malformed_frames; return; }
      ++counters_.syncs;
      // A half whose partner never came belongs to a SYNC that is over now.
      if (assembly_.restart()) ++counters_.late_frames;
      current_sync_counter_ = sync->counter;
      current_sync_time_ns_ = received_ns;
      return;
    }
    case FrameType::sensor_force: {
      const auto f = decode_sensor_force(frame);
      if (!f) { ++counters_.malformed_frames; return; }
      if (assembly_.add_force(f->force_N)) ++counters_.late_frames;
      break;
    }
    case FrameType::sensor_torque: {
      const auto t = decode_sensor_torque(frame);
      if (!t) { ++counters_.malformed_frames; return; }
      if (assembly_.add_torque(t->torque_Nm)) ++counters_.late_frames;
      break;
    }
    case FrameType::heartbeat: {
      if (!decode_heartbeat(frame)) { ++counters_.malformed_frames; return; }
      last_heartbeat_ns_ = clock_.now_ns();
      ++counters_.heartbeats;
      return;
    }
    case FrameType::emcy: {
      const auto e = decode_emcy(frame);
      if (!e) { ++counters_.malformed_frames; return; }
      ++counters_.emcy_frames;
      emcy_code_ = e->error_code;
      return;
    }
    default: return;
  }
  if (!assembly_.complete()) return;
  latest_.values = assembly_.values();
  latest_.sync_counter = current_sync_counter_;
  latest_.sync_time_ns = current_sync_time_ns_;
  ++latest_.sequence;
  latest_.valid = true;
  ++counters_.wrenches;
  assembly_.restart();
  new_wrench_.notify_all();
}

bool SensorListener::poll(std::int64_t timeout_ns) {
  if (receiver_.started()) throw std::logic_error("SensorListener::poll() while the listener thread runs");
  const std::int64_t deadline_ns = monotonic_ns() + timeout_ns;
  const std::uint64_t before = latest().sequence;
  can_frame frame{};
  for (;;) {
    const std::int64_t left_ns = deadline_ns - monotonic_ns();
    if (!bus_->receive(frame, std::max<std::int64_t>(left_ns, 0))) return false;
    handle(frame, monotonic_ns());
    if (latest().sequence != before) return true;
  }
}

void SensorListener::start() {
  receiver_.start(
      *bus_, [this](const can_frame& frame, std::int64_t received_ns) { handle(frame, received_ns); },
      [this](const BusError& e) {
        std::lock_guard lock(mutex_);
        bus_error_ = e.what();
      });
}

void SensorListener::stop() { receiver_.stop(); }

Wrench SensorListener::latest() const {
  std::lock_guard lock(mutex_);
  return latest_;
}

std::optional<Wrench> SensorListener::wait_newer_than(std::uint64_t sequence,
                                                      std::int64_t timeout_ns) {
  std::unique_lock lock(mutex_);
  if (!new_wrench_.wait_for(lock, std::chrono::nanoseconds(timeout_ns), [&] { return latest_.sequence > sequence; })) {
    return std::nullopt;
  }
  return latest_;
}

FaultKind SensorListener::fault_kind_locked(std::int64_t now_ns) const {
  if (!bus_error_.empty()) return FaultKind::bus_error;
  if (emcy_code_ != emcy::kErrorReset) return FaultKind::emergency;
  if (last_heartbeat_ns_ && now_ns - *last_heartbeat_ns_ > heartbeat_timeout_ns_) return FaultKind::heartbeat_lost;
  return FaultKind::none;
}

FaultKind SensorListener::fault_kind() const {
  std::lock_guard lock(mutex_);
  return fault_kind_locked(clock_.now_ns());
}

Fault SensorListener::fault() const {
  std::lock_guard lock(mutex_);
  const std::int64_t now_ns = clock_.now_ns();
  Fault f{fault_kind_locked(now_ns), node_, 0, {}};
  char text[160];
  switch (f.kind) {
    case FaultKind::bus_error: f.reason = bus_error_; break;
    case FaultKind::emergency:
      std::snprintf(text, sizeof text, "%s: EMCY 0x%04x %s", node_description(node_).c_str(), emcy_code_,
                    emcy_description(emcy_code_).data());
      f.reason = text;
      f.code = emcy_code_;
      break;
    case FaultKind::heartbeat_lost:
      std::snprintf(text, sizeof text, "%s: no heartbeat for %lld ms (limit %lld ms)", node_description(node_).c_str(),
                    static_cast<long long>((now_ns - *last_heartbeat_ns_) / 1'000'000),
                    static_cast<long long>(heartbeat_timeout_ns_ / 1'000'000));
      f.reason = text;
      break;
    default: break;
  }
  return f;
}

SensorListenerCounters SensorListener::counters() const {
  std::lock_guard lock(mutex_);
  return counters_;
}

}  // namespace rtm::can
