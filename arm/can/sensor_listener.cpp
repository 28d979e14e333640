#include "arm/can/sensor_listener.h"

#include <cstdio>
#include <stdexcept>

namespace rtm::can {

using std::chrono::steady_clock;

SensorListener::SensorListener(std::unique_ptr<Bus> bus, std::uint8_t node,
                               std::chrono::milliseconds heartbeat_timeout)
    : bus_(std::move(bus)), node_(node), heartbeat_timeout_(heartbeat_timeout) {
  if (!bus_) throw std::invalid_argument("SensorListener: no bus");
  if (!is_sensor_node(node)) {
    throw std::invalid_argument("SensorListener: " + node_description(node) +
                                " is not a force sensor node (0x10 wrist, 0x11 joystick)");
  }
}

SensorListener::SensorListener(std::string_view bus_spec, ForceSensor sensor,
                               std::chrono::milliseconds heartbeat_timeout)
    : SensorListener(open_bus(bus_spec), sensor_node(sensor), heartbeat_timeout) {}

SensorListener::~SensorListener() { stop(); }

void SensorListener::handle(const can_frame& frame, SteadyTime received_at) {
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
      current_sync_time_ = received_at;
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
      last_heartbeat_ = received_at;
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
  latest_.sync_time = current_sync_time_;
  ++latest_.sequence;
  latest_.valid = true;
  ++counters_.wrenches;
  assembly_.restart();
  new_wrench_.notify_all();
}

bool SensorListener::poll(std::chrono::nanoseconds timeout) {
  if (running_.load()) throw std::logic_error("SensorListener::poll() while the listener thread runs");
  const auto deadline = steady_clock::now() + timeout;
  const std::uint64_t before = latest().sequence;
  can_frame frame{};
  for (;;) {
    const auto left = deadline - steady_clock::now();
    if (!bus_->receive(frame, std::max(left, steady_clock::duration::zero()))) return false;
    handle(frame, steady_clock::now());
    if (latest().sequence != before) return true;
  }
}

void SensorListener::start() {
  if (running_.exchange(true)) return;
  thread_ = std::thread([this] { run(); });
}

void SensorListener::stop() {
  if (!running_.exchange(false)) return;
  if (thread_.joinable()) thread_.join();
}

void SensorListener::run() {
  can_frame frame{};
  // The short timeout bounds how long stop() waits for this thread.
  constexpr auto kWakeUp = std::chrono::milliseconds(20);
  while (running_.load()) {
    try {
      if (bus_->receive(frame, kWakeUp)) handle(frame, steady_clock::now());
    } catch (const BusError& e) {
      std::lock_guard lock(mutex_);
      bus_error_ = e.what();
      return;
    }
  }
}

Wrench SensorListener::latest() const {
  std::lock_guard lock(mutex_);
  return latest_;
}

std::optional<Wrench> SensorListener::wait_newer_than(std::uint64_t sequence,
                                                      std::chrono::nanoseconds timeout) {
  std::unique_lock lock(mutex_);
  if (!new_wrench_.wait_for(lock, timeout, [&] { return latest_.sequence > sequence; })) {
    return std::nullopt;
  }
  return latest_;
}

std::string SensorListener::fault() const {
  std::lock_guard lock(mutex_);
  if (!bus_error_.empty()) return bus_error_;
  char text[160];
  if (emcy_code_ != emcy::kErrorReset) {
    std::snprintf(text, sizeof text, "%s: EMCY 0x%04x %s", node_description(node_).c_str(),
                  emcy_code_, emcy_description(emcy_code_).data());
    return text;
  }
  if (last_heartbeat_) {
    const auto silent =
        std::chrono::duration_cast<std::chrono::milliseconds>(steady_clock::now() - *last_heartbeat_);
    if (silent > heartbeat_timeout_) {
      std::snprintf(text, sizeof text, "%s: no heartbeat for %lld ms (limit %lld ms)",
                    node_description(node_).c_str(), static_cast<long long>(silent.count()),
                    static_cast<long long>(heartbeat_timeout_.count()));
      return text;
    }
  }
  return {};
}

SensorListenerCounters SensorListener::counters() const {
  std::lock_guard lock(mutex_);
  return counters_;
}

}  // namespace rtm::can
