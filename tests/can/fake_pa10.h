// A protocol-level fake of the PA10's CAN nodes (7 drives, 2 force sensors) for tests and
// benchmarks of the master. It answers exactly what docs/can-protocol.md specifies: boot-up and
// heartbeats, NMT, the SDO objects 0x6060/0x6061, RPDOs latched on SYNC, the CiA 402 state
// machine, the 3-SYNC RPDO timeout, TPDOs after each SYNC. Positions integrate the latched
// target velocity over a fixed 2 ms per SYNC, so lock-step results are exact.
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <set>
#include <thread>

#include "arm/can/bus.h"
#include "arm/can/cia402.h"
#include "arm/can/protocol.h"

namespace rtm::can::testing {

class FakePa10 {
 public:
  struct Options {
    bool drives = true;
    bool sensors = true;
    std::set<std::uint8_t> silent_nodes;  // never boot, never answer
    bool refuse_mode_of_operation = false;  // SDO abort on 0x6060
    std::chrono::milliseconds heartbeat_period{100};
  };

  FakePa10(std::unique_ptr<Bus> bus, Options options) : bus_(std::move(bus)), options_(std::move(options)) {
    thread_ = std::thread([this] { run(); });
  }
  ~FakePa10() {
    running_ = false;
    thread_.join();
  }

  // ---- controls for tests ----
  void set_wrench(ForceSensor sensor, std::array<double, 6> values) {
    std::lock_guard lock(mutex_);
    wrench_[sensor == ForceSensor::wrist ? 0 : 1] = values;
  }
  // The drive faults (device hardware): EMCY 0x5000 and statusword fault from the next SYNC.
  void inject_fault(std::uint8_t drive) {
    std::lock_guard lock(mutex_);
    drives_[static_cast<std::size_t>(joint_index_of(drive))].cia.raise_fault();
    send(encode_emcy(drive, emcy::kDeviceHardware, 0x01));
  }
  // The drive lost its commands (as after a host stall of the master): EMCY 0x8250 and fault
  // from the next SYNC, as its own 3-SYNC RPDO timeout does; a fault reset clears it.
  void inject_rpdo_timeout(std::uint8_t drive) {
    std::lock_guard lock(mutex_);
    drives_[static_cast<std::size_t>(joint_index_of(drive))].cia.raise_fault();
    send(encode_emcy(drive, emcy::kRpdoTimeout, 0x01));
  }
  // The drive's fault cannot be reset: it faults again at every SYNC (broken hardware).
  void hold_in_fault(std::uint8_t drive) {
    std::lock_guard lock(mutex_);
    drives_[static_cast<std::size_t>(joint_index_of(drive))].stuck_in_fault = true;
  }
  void silence(std::uint8_t node) {
    std::lock_guard lock(mutex_);
    options_.silent_nodes.insert(node);
  }
  // Skip this drive's next TPDO (the master then sees it missing for that SYNC).
  void drop_next_tpdo(std::uint8_t drive) {
    std::lock_guard lock(mutex_);
    drives_[static_cast<std::size_t>(joint_index_of(drive))].drop_next = true;
  }

  // ---- observations ----
  DriveState drive_state(std::uint8_t drive) const {
    std::lock_guard lock(mutex_);
    return drives_[static_cast<std::size_t>(joint_index_of(drive))].cia.state();
  }
  double position_rad(std::uint8_t drive) const {
    std::lock_guard lock(mutex_);
    return drives_[static_cast<std::size_t>(joint_index_of(drive))].position_rad;
  }
  double latched_velocity_rad_s(std::uint8_t drive) const {
    std::lock_guard lock(mutex_);
    return drives_[static_cast<std::size_t>(joint_index_of(drive))].latched_velocity_rad_s;
  }
  std::uint16_t latched_controlword(std::uint8_t drive) const {
    std::lock_guard lock(mutex_);
    return drives_[static_cast<std::size_t>(joint_index_of(drive))].latched_controlword;
  }
  std::int8_t mode_of_operation(std::uint8_t drive) const {
    std::lock_guard lock(mutex_);
    return drives_[static_cast<std::size_t>(joint_index_of(drive))].mode;
  }
  NmtState nmt_state() const {
    std::lock_guard lock(mutex_);
    return nmt_;
  }
  std::uint64_t syncs_seen() const {
    std::lock_guard lock(mutex_);
    return syncs_;
  }
  std::uint8_t last_sync_counter() const {
    std::lock_guard lock(mutex_);
    return last_sync_counter_;
  }

 private:
  struct Drive {
    Cia402Drive cia;
    std::int8_t mode = 0;
    bool rpdo_since_sync = false;
    int syncs_without_rpdo = 0;
    std::uint16_t pending_controlword = 0;
    double pending_velocity_rad_s = 0;
    std::uint16_t latched_controlword = 0;
    double latched_velocity_rad_s = 0;
    double position_rad = 0;
    bool drop_next = false;
    bool stuck_in_fault = false;
  };
  static constexpr double kSyncPeriod_s = 0.002;

  void send(const Result<can_frame>& frame) {
    if (frame) bus_->send(*frame);
  }
  bool silent(std::uint8_t node) const { return options_.silent_nodes.count(node) != 0; }

  std::set<std::uint8_t> nodes() const {
    std::set<std::uint8_t> n;
    if (options_.drives) {
      for (int j = 0; j < kDriveCount; ++j) n.insert(drive_node(j));
    }
    if (options_.sensors) {
      n.insert(kWristSensorNode);
      n.insert(kJoystickSensorNode);
    }
    return n;
  }

  void heartbeat_all(NmtState state) {
    for (std::uint8_t node : nodes()) {
      if (!silent(node)) send(encode_heartbeat(node, state));
    }
  }

  void run() {
    {
      std::lock_guard lock(mutex_);
      heartbeat_all(NmtState::boot_up);
      nmt_ = NmtState::pre_operational;
    }
    auto next_heartbeat = std::chrono::steady_clock::now() + options_.heartbeat_period;
    can_frame frame{};
    while (running_) {
      bool got = false;
      try {
        got = bus_->receive(frame, 5'000'000);
      } catch (const BusError&) {
        return;  // the hub went away: the test is ending
      }
      std::lock_guard lock(mutex_);
      if (got) handle(frame);
      const auto now = std::chrono::steady_clock::now();
      if (now >= next_heartbeat) {
        heartbeat_all(nmt_);
        next_heartbeat = now + options_.heartbeat_period;
      }
    }
  }

  void handle(const can_frame& frame) {
    const Classified c = classify(frame);
    switch (c.type) {
      case FrameType::nmt: {
        const auto nmt = decode_nmt(frame);
        if (!nmt) return;
        if (nmt->command == NmtCommand::start) nmt_ = NmtState::operational;
        if (nmt->command == NmtCommand::stop) nmt_ = NmtState::stopped;
        if (nmt->command == NmtCommand::enter_pre_operational) nmt_ = NmtState::pre_operational;
        return;
      }
      case FrameType::sdo_request: {
        if (!options_.drives || !is_drive_node(c.node) || silent(c.node)) return;
        const auto r = decode_sdo_request(frame);
        if (!r) return;
        Drive& d = drives_[static_cast<std::size_t>(joint_index_of(c.node))];
        SdoResponse answer{c.node, SdoResponseKind::abort, r->index, r->subindex, sdo::kAbortNoObject, 0};
        if (r->kind == SdoRequestKind::download && r->index == object::kModesOfOperation) {
          if (options_.refuse_mode_of_operation) {
            answer.data = sdo::kAbortValueRange;
          } else if (nmt_ != NmtState::pre_operational) {
            answer.data = sdo::kAbortWrongState;
          } else {
            d.mode = static_cast<std::int8_t>(r->data);
            answer = SdoResponse{c.node, SdoResponseKind::download_ack, r->index, r->subindex, 0, 0};
          }
        } else if (r->kind == SdoRequestKind::upload && r->index == object::kModesOfOperationDisplay) {
          answer = SdoResponse{c.node, SdoResponseKind::upload_data, r->index, r->subindex,
                               static_cast<std::uint8_t>(d.mode), 1};
        }
        send(encode_sdo_response(answer));
        return;
      }
      case FrameType::drive_command: {
        if (!options_.drives || nmt_ != NmtState::operational) return;
        const auto cmd = decode_drive_command(frame);
        if (!cmd) return;
        Drive& d = drives_[static_cast<std::size_t>(joint_index_of(cmd->drive))];
        d.pending_controlword = cmd->controlword;
        d.pending_velocity_rad_s = cmd->target_velocity_rad_s;
        d.rpdo_since_sync = true;
        return;
      }
      case FrameType::sync: {
        const auto sync = decode_sync(frame);
        if (!sync) return;
        ++syncs_;
        last_sync_counter_ = sync->counter;
        if (nmt_ != NmtState::operational) return;
        if (options_.drives) on_sync_drives();
        if (options_.sensors) on_sync_sensors();
        return;
      }
      default: return;
    }
  }

  void on_sync_drives() {
    for (int j = 0; j < kDriveCount; ++j) {
      Drive& d = drives_[static_cast<std::size_t>(j)];
      const std::uint8_t node = drive_node(j);
      if (silent(node)) continue;
      if (d.rpdo_since_sync) {
        d.syncs_without_rpdo = 0;
        d.latched_controlword = d.pending_controlword;
        d.latched_velocity_rad_s = d.pending_velocity_rad_s;
        d.cia.apply_controlword(d.latched_controlword);
      } else if (++d.syncs_without_rpdo >= 3 && d.cia.state() != DriveState::fault) {
        d.cia.raise_fault();
        send(encode_emcy(node, emcy::kRpdoTimeout, 0x01));
      }
      d.rpdo_since_sync = false;
      if (d.stuck_in_fault) d.cia.raise_fault();
      const double velocity = d.cia.follows_target_velocity() ? d.latched_velocity_rad_s : 0.0;
      d.position_rad += velocity * kSyncPeriod_s;
      if (d.drop_next) {
        d.drop_next = false;
        continue;
      }
      send(encode_drive_feedback(DriveFeedback{node, d.cia.statusword(), d.position_rad, velocity}));
    }
  }

  void on_sync_sensors() {
    for (std::size_t s = 0; s < 2; ++s) {
      const std::uint8_t node = s == 0 ? kWristSensorNode : kJoystickSensorNode;
      if (silent(node)) continue;
      const auto& w = wrench_[s];
      send(encode_sensor_force(SensorForce{node, {w[0], w[1], w[2]}}));
      send(encode_sensor_torque(SensorTorque{node, {w[3], w[4], w[5]}}));
    }
  }

  std::unique_ptr<Bus> bus_;
  Options options_;
  mutable std::mutex mutex_;
  std::array<Drive, kDriveCount> drives_{};
  std::array<std::array<double, 6>, 2> wrench_{};
  NmtState nmt_ = NmtState::boot_up;
  std::uint64_t syncs_ = 0;
  std::uint8_t last_sync_counter_ = 0;
  std::atomic<bool> running_{true};
  std::thread thread_;
};

}  // namespace rtm::can::testing
