#include "arm/can/master.h"

#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <sys/prctl.h>
#include <time.h>

#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <optional>
#include <span>
#include <stdexcept>

namespace rtm::can {

using std::chrono::duration_cast;
using std::chrono::milliseconds;
using std::chrono::nanoseconds;
using std::chrono::steady_clock;

std::string_view to_string(FaultKind kind) {
  switch (kind) {
    case FaultKind::none: return "none";
    case FaultKind::drive_fault: return "drive fault";
    case FaultKind::drive_disabled: return "drive disabled";
    case FaultKind::emergency: return "emergency";
    case FaultKind::heartbeat_lost: return "heartbeat lost";
    case FaultKind::bus_error: return "bus error";
    case FaultKind::missing_feedback: return "missing feedback";
    case FaultKind::node_not_operational: return "node not operational";
    case FaultKind::cycle_owner_lost: return "cycle owner lost";
  }
  return "invalid";
}

namespace {

constexpr std::size_t kSensorCount = 2;
constexpr std::size_t sensor_slot(ForceSensor s) { return s == ForceSensor::wrist ? 0 : 1; }

timespec to_timespec(steady_clock::time_point t) {
  // steady_clock is CLOCK_MONOTONIC on Linux (libstdc++), so its epoch is the clock's.
  const auto ns = duration_cast<nanoseconds>(t.time_since_epoch()).count();
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(ns / 1'000'000'000);
  ts.tv_nsec = static_cast<long>(ns % 1'000'000'000);
  return ts;
}

void sleep_until(steady_clock::time_point t) {
  const timespec ts = to_timespec(t);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

// The fault as kept by the cycle: a fixed buffer so latching one does not allocate.
struct FaultRecord {
  FaultKind kind = FaultKind::none;
  std::uint8_t node = 0;
  std::uint16_t code = 0;
  std::array<char, 192> reason{};
};

}  // namespace

struct Pa10Master::Impl {
  std::unique_ptr<Bus> drive_bus;
  std::unique_ptr<Bus> separate_sensor_bus;  // null: sensors share drive_bus
  Bus* sensor_bus = nullptr;
  MasterConfig config;
  std::array<bool, kSensorCount> sensor_enabled{};

  // ---- touched only by the thread that cycles (start/step/run_periodic) ----
  std::uint8_t sync_counter = 0;  // of the last SYNC sent
  std::uint64_t cycle = 0;
  steady_clock::time_point sync_time{};
  bool window_open = false;
  std::array<bool, kDriveCount> got_feedback{};
  std::array<DriveFeedback, kDriveCount> feedback{};
  std::array<std::uint16_t, kDriveCount> last_statusword{};
  std::array<int, kDriveCount> missed{};
  std::array<bool, kSensorCount> got_force{}, got_torque{};
  std::array<std::array<double, 6>, kSensorCount> wrench_values{};
  std::array<Cia402Enabler, kDriveCount> enablers{};
  std::array<std::optional<steady_clock::time_point>, 128> last_heartbeat{};
  std::array<NmtState, 128> nmt_state{};
  bool started = false;     // NMT start sent: nodes must stay operational from then on
  bool enabling = false;    // startup or recovery: drive the CiA 402 enable sequence
  bool recovering = false;  // after fault_reset()
  steady_clock::time_point state_check_from{};  // heartbeat states are checked from then on
  steady_clock::time_point recovery_deadline{};
  std::uint8_t sdo_waiting_node = 0;
  std::optional<SdoResponse> sdo_response;
  MasterCounters counters{};
  FaultRecord fault{};       // cycle's copy, published with the rest
  std::array<double, kDriveCount> command_rad_s{};
  std::uint64_t command_sequence = 0;  // of the target in command_rad_s; 0 = zero, not a target
  bool quick_stop = false;   // this cycle sends quick stop to every drive
  // After a quick stop ends, drives still report quick stop active until they have latched
  // "enable operation": that state is no fault until this deadline (or all are enabled again).
  std::optional<steady_clock::time_point> quick_stop_release_deadline;

  // ---- shared with other threads, under mutex ----
  mutable std::mutex mutex;
  std::array<double, kDriveCount> shared_target_rad_s{};
  bool shared_target_valid = false;
  std::uint64_t shared_target_sequence = 0;
  SentTarget shared_last_sent{};
  bool shared_reset_requested = false;
  bool shared_quick_stop_requested = false;
  bool shared_quick_stopped = false;
  JointState shared_state{};
  std::array<Wrench, kSensorCount> shared_wrench{};
  FaultRecord shared_fault{};
  MasterCounters shared_counters{};
  bool shared_enabled = false;

  Impl(std::unique_ptr<Bus> drives, std::unique_ptr<Bus> sensors, MasterConfig cfg)
      : drive_bus(std::move(drives)), separate_sensor_bus(std::move(sensors)), config(std::move(cfg)) {
    if (!drive_bus) throw std::invalid_argument("Pa10Master: no drive bus");
    sensor_bus = separate_sensor_bus ? separate_sensor_bus.get() : drive_bus.get();
    for (ForceSensor s : config.sensors) sensor_enabled[sensor_slot(s)] = true;
    if (config.period <= nanoseconds(0)) throw std::invalid_argument("Pa10Master: period must be > 0");
  }

  std::string describe_buses() const {
    return separate_sensor_bus ? drive_bus->name() + " (sensors on " + sensor_bus->name() + ")"
                               : drive_bus->name();
  }

  [[noreturn]] void fail_start(const std::string& what) const {
    throw std::runtime_error("PA10 master on " + describe_buses() + ": " + what);
  }

  // ---- faults ----------------------------------------------------------------------------

  void latch_fault(FaultKind kind, std::uint8_t node, std::uint16_t code, const char* format, ...)
      __attribute__((format(printf, 5, 6))) {
    if (fault.kind != FaultKind::none) return;  // the first cause is the one to report
    fault.kind = kind;
    fault.node = node;
    fault.code = code;
    va_list args;
    va_start(args, format);
    std::vsnprintf(fault.reason.data(), fault.reason.size(), format, args);
    va_end(args);
    recovering = false;
    enabling = false;
  }

  // ---- sending ---------------------------------------------------------------------------

  void send(Bus& bus, const Result<can_frame>& frame) {
    if (!frame.ok()) return;  // encoders only fail on NaN/ids, excluded before this point
    if (!bus.send(*frame)) ++counters.send_dropped;
  }

  void send_nmt_all(NmtCommand command) {
    send(*drive_bus, encode_nmt(command, kNmtAllNodes));
    if (separate_sensor_bus) send(*separate_sensor_bus, encode_nmt(command, kNmtAllNodes));
  }

  // A cycle's frames, collected for one send_batch().
  std::array<can_frame, kDriveCount + 1> outgoing{};
  std::size_t outgoing_count = 0;
  void add(const Result<can_frame>& frame) {
    if (frame.ok() && outgoing_count < outgoing.size()) outgoing[outgoing_count++] = *frame;
  }

  // ---- receiving -------------------------------------------------------------------------

  bool sensor_expected(std::uint8_t node) const {
    return (node == kWristSensorNode && sensor_enabled[0]) ||
           (node == kJoystickSensorNode && sensor_enabled[1]);
  }
  bool node_expected(std::uint8_t node) const { return is_drive_node(node) || sensor_expected(node); }

  void handle(const can_frame& frame, steady_clock::time_point now) {
    const Classified c = classify(frame);
    switch (c.type) {
      case FrameType::drive_feedback: {
        const auto fb = decode_drive_feedback(frame);
        if (!fb) { ++counters.malformed_frames; return; }
        const int j = joint_index_of(fb->drive);
        if (!window_open) { ++counters.late_frames; return; }
        if (got_feedback[static_cast<std::size_t>(j)]) ++counters.late_frames;  // keep the newer
        got_feedback[static_cast<std::size_t>(j)] = true;
        feedback[static_cast<std::size_t>(j)] = *fb;
        return;
      }
      case FrameType::sensor_force:
      case FrameType::sensor_torque: {
        if (!sensor_expected(c.node)) return;
        const std::size_t s = c.node == kWristSensorNode ? 0 : 1;
        if (c.type == FrameType::sensor_force) {
          const auto f = decode_sensor_force(frame);
          if (!f) { ++counters.malformed_frames; return; }
          if (!window_open) { ++counters.late_frames; return; }
          if (got_force[s]) ++counters.late_frames;
          got_force[s] = true;
          for (int i = 0; i < 3; ++i) wrench_values[s][static_cast<std::size_t>(i)] = f->force_N[static_cast<std::size_t>(i)];
        } else {
          const auto t = decode_sensor_torque(frame);
          if (!t) { ++counters.malformed_frames; return; }
          if (!window_open) { ++counters.late_frames; return; }
          if (got_torque[s]) ++counters.late_frames;
          got_torque[s] = true;
          for (int i = 0; i < 3; ++i) wrench_values[s][static_cast<std::size_t>(3 + i)] = t->torque_Nm[static_cast<std::size_t>(i)];
        }
        return;
      }
      case FrameType::heartbeat: {
        const auto hb = decode_heartbeat(frame);
        if (!hb) { ++counters.malformed_frames; return; }
        last_heartbeat[hb->node] = now;
        nmt_state[hb->node] = hb->state;
        // A heartbeat sent just before a node processed NMT start may still say pre-operational:
        // the state is checked only once a heartbeat period has passed since the start.
        if (started && !enabling && now > state_check_from && node_expected(hb->node) &&
            hb->state != NmtState::operational) {
          latch_fault(FaultKind::node_not_operational, hb->node, static_cast<std::uint16_t>(hb->state),
                      "%s: heartbeat reports %s instead of operational",
                      node_description(hb->node).c_str(), to_string(hb->state).data());
        }
        return;
      }
      case FrameType::emcy: {
        const auto e = decode_emcy(frame);
        if (!e) { ++counters.malformed_frames; return; }
        ++counters.emcy_frames;
        if (e->error_code != emcy::kErrorReset && node_expected(e->node) && !enabling) {
          latch_fault(FaultKind::emergency, e->node, e->error_code, "%s: EMCY 0x%04x %s",
                      node_description(e->node).c_str(), e->error_code,
                      emcy_description(e->error_code).data());
        }
        return;
      }
      case FrameType::sdo_response: {
        const auto r = decode_sdo_response(frame);
        if (!r) { ++counters.malformed_frames; return; }
        if (sdo_waiting_node != 0 && r->node == sdo_waiting_node) sdo_response = *r;
        return;
      }
      case FrameType::nmt:
      case FrameType::sync:
      case FrameType::drive_command:
      case FrameType::sdo_request: ++counters.foreign_frames; return;
      case FrameType::unknown: ++counters.unknown_frames; return;
    }
  }

  // Reads everything already queued on both buses without waiting.
  void drain() {
    can_frame frame{};
    const auto now = steady_clock::now();
    while (drive_bus->receive(frame, nanoseconds(0))) handle(frame, now);
    if (separate_sensor_bus) {
      while (separate_sensor_bus->receive(frame, nanoseconds(0))) handle(frame, now);
    }
  }

  // Handles frames until `done()` or the deadline; true when done.
  template <class Done>
  bool receive_until(steady_clock::time_point deadline, Done done) {
    for (;;) {
      drain();
      if (done()) return true;
      const auto now = steady_clock::now();
      if (now >= deadline) return false;
      pollfd fds[2] = {{drive_bus->pollable_fd(), POLLIN, 0}, {-1, POLLIN, 0}};
      if (separate_sensor_bus) fds[1].fd = separate_sensor_bus->pollable_fd();
      const auto left = duration_cast<nanoseconds>(deadline - now).count();
      timespec ts{static_cast<time_t>(left / 1'000'000'000), static_cast<long>(left % 1'000'000'000)};
      ppoll(fds, separate_sensor_bus ? 2 : 1, &ts, nullptr);
    }
  }

  bool window_complete() const {
    for (bool got : got_feedback) {
      if (!got) return false;
    }
    for (std::size_t s = 0; s < kSensorCount; ++s) {
      if (sensor_enabled[s] && !(got_force[s] && got_torque[s])) return false;
    }
    return true;
  }

  // ---- the cycle -------------------------------------------------------------------------

  void take_requests() {
    std::lock_guard lock(mutex);
    if (shared_reset_requested) {
      shared_reset_requested = false;
      fault = FaultRecord{};
      shared_fault = fault;
      recovering = true;
      enabling = true;
      missed.fill(0);
      recovery_deadline = steady_clock::now() + config.enable_timeout;
      shared_target_valid = false;
    }
    const bool was_quick_stop = quick_stop;
    quick_stop = shared_quick_stop_requested && fault.kind == FaultKind::none && !enabling;
    if (was_quick_stop && !quick_stop) {
      quick_stop_release_deadline = steady_clock::now() + config.enable_timeout;
    }
    if (quick_stop) quick_stop_release_deadline.reset();
    if (fault.kind == FaultKind::none && !enabling && !quick_stop && shared_target_valid) {
      command_rad_s = shared_target_rad_s;
      command_sequence = shared_target_sequence;
    } else {
      command_rad_s.fill(0.0);
      command_sequence = 0;
    }
  }

  // A drive in quick stop active is where the master put it, not a drive that left by itself.
  bool quick_stop_expected(steady_clock::time_point now) const {
    return quick_stop || (quick_stop_release_deadline && now < *quick_stop_release_deadline);
  }

  void check_heartbeats(steady_clock::time_point now) {
    // Once latched, a fault is not formatted again each cycle (node names may allocate).
    if (!started || fault.kind != FaultKind::none) return;
    for (unsigned node = 1; node < last_heartbeat.size(); ++node) {
      const auto n = static_cast<std::uint8_t>(node);
      if (!node_expected(n) || !last_heartbeat[node]) continue;
      const auto silent = duration_cast<milliseconds>(now - *last_heartbeat[node]);
      if (silent > config.heartbeat_timeout) {
        latch_fault(FaultKind::heartbeat_lost, n, 0, "%s: no heartbeat for %lld ms (limit %lld ms)",
                    node_description(n).c_str(), static_cast<long long>(silent.count()),
                    static_cast<long long>(config.heartbeat_timeout.count()));
      }
    }
  }

  // Writes the 7 RPDOs and SYNC; opens the window for this SYNC's answers.
  void send_cycle() {
    if (recovering) {
      // Nodes that dropped out of operational are started again; harmless for the others.
      send_nmt_all(NmtCommand::start);
      state_check_from = steady_clock::now() + config.heartbeat_timeout;
    }
    for (int j = 0; j < kDriveCount; ++j) {
      const auto i = static_cast<std::size_t>(j);
      std::uint16_t cw;
      if (enabling) {
        cw = enablers[i].next_controlword(last_statusword[i], /*reset_faults=*/true);
      } else if (quick_stop && fault.kind == FaultKind::none) {
        cw = controlword::kQuickStop;
      } else if (fault.kind != FaultKind::none) {
        // Hold: enabled drives stay enabled at zero velocity, the others stay off.
        const auto state = state_from_statusword(last_statusword[i]);
        cw = state == DriveState::operation_enabled ? controlword::kEnableOperation
                                                    : controlword::kDisableVoltage;
      } else {
        cw = enablers[i].next_controlword(last_statusword[i], /*reset_faults=*/false);
      }
      add(encode_drive_command(DriveCommand{drive_node(j), cw, command_rad_s[i]}));
    }
    sync_counter = next_sync_counter(sync_counter);
    add(encode_sync(sync_counter));
    // The seven RPDOs and SYNC leave in one write: a node woken by the first frame cannot
    // hold the rest back, and on a real bus they go out back to back.
    sync_time = steady_clock::now();
    const std::size_t sent = drive_bus->send_batch(std::span<const can_frame>(outgoing.data(), outgoing_count));
    counters.send_dropped += outgoing_count - sent;
    outgoing_count = 0;
    if (command_sequence != 0) publish_sent(command_sequence);
    if (separate_sensor_bus) send(*separate_sensor_bus, encode_sync(sync_counter));
    ++cycle;
    ++counters.cycles;
    got_feedback.fill(false);
    got_force.fill(false);
    got_torque.fill(false);
    window_open = true;
  }

  // Closes the window of the last SYNC: publishes what arrived and checks the drives.
  void close_window(steady_clock::time_point now) {
    window_open = false;
    bool all_enabled = true;
    bool all_quick_stopped = quick_stop;
    bool all_operation_enabled = true;
    const bool quick_stop_ok = quick_stop_expected(now);
    for (int j = 0; j < kDriveCount; ++j) {
      const auto i = static_cast<std::size_t>(j);
      if (got_feedback[i]) {
        missed[i] = 0;
        last_statusword[i] = feedback[i].statusword;
      } else if (started && ++missed[i] > config.missed_feedback_limit &&
                 fault.kind == FaultKind::none) {
        latch_fault(FaultKind::missing_feedback, drive_node(j), 0,
                    "%s: no TPDO for %d consecutive SYNCs", node_description(drive_node(j)).c_str(),
                    missed[i]);
      }
      const auto state = state_from_statusword(last_statusword[i]);
      const bool quick_stopped = state == DriveState::quick_stop_active;
      const bool enabled = state == DriveState::operation_enabled || (quick_stop_ok && quick_stopped);
      all_enabled = all_enabled && enabled && got_feedback[i];
      all_quick_stopped = all_quick_stopped && quick_stopped && got_feedback[i];
      all_operation_enabled = all_operation_enabled && state == DriveState::operation_enabled;
      if (enabling || !started || enabled || fault.kind != FaultKind::none) continue;
      if (state == DriveState::fault || state == DriveState::fault_reaction_active) {
        latch_fault(FaultKind::drive_fault, drive_node(j), last_statusword[i],
                    "%s: statusword 0x%04x (%s)", node_description(drive_node(j)).c_str(),
                    last_statusword[i], state ? to_string(*state).data() : "?");
      } else {
        latch_fault(FaultKind::drive_disabled, drive_node(j), last_statusword[i],
                    "%s: left operation enabled, statusword 0x%04x (%s)",
                    node_description(drive_node(j)).c_str(), last_statusword[i],
                    state ? to_string(*state).data() : "unknown state");
      }
    }
    if (!quick_stop && quick_stop_release_deadline && all_operation_enabled) {
      quick_stop_release_deadline.reset();
    }
    if (recovering) {
      if (all_enabled) {
        recovering = false;
        enabling = false;
      } else if (now > recovery_deadline) {
        for (int j = 0; j < kDriveCount; ++j) {
          const auto state = state_from_statusword(last_statusword[static_cast<std::size_t>(j)]);
          if (state == DriveState::operation_enabled) continue;
          recovering = false;
          enabling = false;
          latch_fault(FaultKind::drive_fault, drive_node(j), last_statusword[static_cast<std::size_t>(j)],
                      "fault reset failed: %s still %s after %lld ms",
                      node_description(drive_node(j)).c_str(), state ? to_string(*state).data() : "in an unknown state",
                      static_cast<long long>(config.enable_timeout.count()));
          break;
        }
      }
    }
    publish(all_enabled, all_quick_stopped);
  }

  void publish(bool all_enabled, bool all_quick_stopped = false) {
    std::lock_guard lock(mutex);
    JointState& s = shared_state;
    for (int j = 0; j < kDriveCount; ++j) {
      const auto i = static_cast<std::size_t>(j);
      if (!got_feedback[i]) continue;
      s.position_rad[i] = feedback[i].position_rad;
      s.velocity_rad_s[i] = feedback[i].velocity_rad_s;
      s.statusword[i] = feedback[i].statusword;
    }
    s.sync_counter = sync_counter;
    s.sync_time = sync_time;
    s.cycle = cycle;
    s.complete = true;
    for (bool got : got_feedback) s.complete = s.complete && got;
    for (std::size_t k = 0; k < kSensorCount; ++k) {
      if (!(sensor_enabled[k] && got_force[k] && got_torque[k])) continue;
      Wrench& w = shared_wrench[k];
      w.values = wrench_values[k];
      w.sync_counter = sync_counter;
      w.sync_time = sync_time;
      ++w.sequence;
      w.valid = true;
    }
    if (fault.kind != FaultKind::none && shared_fault.kind == FaultKind::none) {
      shared_target_valid = false;  // after a fault the old target must not come back
    }
    shared_fault = fault;
    shared_enabled = all_enabled && fault.kind == FaultKind::none && !enabling;
    shared_quick_stopped = all_quick_stopped && shared_quick_stop_requested;
    shared_counters = counters;
  }

  // Right after the RPDOs of target `sequence` (and the SYNC behind them) were written: the end
  // of the sample-to-bus path.
  void publish_sent(std::uint64_t sequence) {
    timespec realtime{};
    clock_gettime(CLOCK_REALTIME, &realtime);
    const std::int64_t sent_ns = std::int64_t{realtime.tv_sec} * 1'000'000'000 + realtime.tv_nsec;
    std::lock_guard lock(mutex);
    shared_last_sent = SentTarget{sequence, sent_ns};
  }

  void bus_failure(const std::exception& e) {
    latch_fault(FaultKind::bus_error, 0, 0, "%s", e.what());
    publish(false);
  }

  // One lock-step cycle; true when every expected answer came.
  bool step() {
    window_open = false;
    drain();  // anything now is an answer to an older SYNC (late) or asynchronous
    const auto now = steady_clock::now();
    check_heartbeats(now);
    take_requests();
    send_cycle();
    const bool complete =
        receive_until(steady_clock::now() + config.step_timeout, [this] { return window_complete(); });
    if (!complete) ++counters.step_timeouts;
    close_window(steady_clock::now());
    return complete;
  }

  // One periodic cycle, in two halves. Receive: the window of the previous SYNC closes now
  // and what arrived is published. Transmit: the latest target goes out with the next SYNC.
  void periodic_receive() {
    drain();
    const auto now = steady_clock::now();
    if (cycle > 0) close_window(now);
    check_heartbeats(now);
  }
  void periodic_transmit() {
    take_requests();
    send_cycle();
  }
  void periodic_cycle() {
    periodic_receive();
    periodic_transmit();
  }

  // ---- startup ---------------------------------------------------------------------------

  SdoResponse sdo_transfer(const SdoRequest& request, const char* what) {
    sdo_response.reset();
    sdo_waiting_node = request.node;
    send(*drive_bus, encode_sdo_request(request));
    const bool answered = receive_until(steady_clock::now() + config.sdo_timeout, [&] {
      return sdo_response && sdo_response->index == request.index &&
             sdo_response->subindex == request.subindex;
    });
    sdo_waiting_node = 0;
    char text[96];
    std::snprintf(text, sizeof text, "%s 0x%04x:%02x", what, request.index, request.subindex);
    if (!answered) {
      fail_start("no SDO response from " + node_description(request.node) + " to " + text +
                 " within " + std::to_string(config.sdo_timeout.count()) + " ms");
    }
    if (sdo_response->kind == SdoResponseKind::abort) {
      char code[16];
      std::snprintf(code, sizeof code, "0x%08x", sdo_response->data);
      fail_start(node_description(request.node) + " aborted the SDO " + text + " with code " + code);
    }
    return *sdo_response;
  }

  void start() {
    if (started) fail_start("start() called twice");
    // 1. Every node must be alive: a boot-up message or a heartbeat.
    const auto boot_deadline = steady_clock::now() + config.boot_timeout;
    auto all_seen = [this] {
      for (unsigned n = 1; n < last_heartbeat.size(); ++n) {
        if (node_expected(static_cast<std::uint8_t>(n)) && !last_heartbeat[n]) return false;
      }
      return true;
    };
    if (!receive_until(boot_deadline, all_seen)) {
      std::string missing;
      for (unsigned n = 1; n < last_heartbeat.size(); ++n) {
        if (!node_expected(static_cast<std::uint8_t>(n)) || last_heartbeat[n]) continue;
        if (!missing.empty()) missing += ", ";
        missing += node_description(n);
      }
      fail_start("no boot-up or heartbeat within " + std::to_string(config.boot_timeout.count()) +
                 " ms from " + missing);
    }
    // 2. Configuration happens in pre-operational (nodes left operational go back there).
    send_nmt_all(NmtCommand::enter_pre_operational);
    for (int j = 0; j < kDriveCount; ++j) {
      const std::uint8_t node = drive_node(j);
      sdo_transfer(SdoRequest{node, SdoRequestKind::download, object::kModesOfOperation, 0,
                              static_cast<std::uint8_t>(object::kCyclicSynchronousVelocityMode), 1},
                   "write mode of operation");
      const SdoResponse mode = sdo_transfer(
          SdoRequest{node, SdoRequestKind::upload, object::kModesOfOperationDisplay, 0, 0, 0},
          "read mode of operation display");
      const auto value = static_cast<std::int8_t>(mode.data & 0xFF);
      if (mode.kind != SdoResponseKind::upload_data ||
          value != object::kCyclicSynchronousVelocityMode) {
        fail_start(node_description(node) + ": mode of operation display 0x6061 reads " +
                   std::to_string(value) + " after writing 9 (cyclic synchronous velocity)");
      }
    }
    // 3. Operational: PDOs flow from the next SYNC on.
    send_nmt_all(NmtCommand::start);
    // Heartbeats sent before the start may still say pre-operational: restart the watch.
    const auto now = steady_clock::now();
    for (unsigned n = 1; n < last_heartbeat.size(); ++n) {
      if (last_heartbeat[n]) last_heartbeat[n] = now;
    }
    started = true;
    enabling = true;
    state_check_from = now + config.heartbeat_timeout;
    // 4. Cycle until every drive reports operation enabled.
    const auto enable_deadline = now + config.enable_timeout;
    auto next = steady_clock::now();
    for (;;) {
      step();
      if (fault.kind != FaultKind::none) fail_start(std::string("fault while enabling: ") + fault.reason.data());
      bool all_enabled = true;
      for (int j = 0; j < kDriveCount; ++j) {
        const auto i = static_cast<std::size_t>(j);
        all_enabled = all_enabled && got_feedback[i] &&
                      state_from_statusword(last_statusword[i]) == DriveState::operation_enabled;
      }
      if (all_enabled) break;
      if (steady_clock::now() > enable_deadline) {
        std::string states;
        for (int j = 0; j < kDriveCount; ++j) {
          const auto i = static_cast<std::size_t>(j);
          const auto state = state_from_statusword(last_statusword[i]);
          if (got_feedback[i] && state == DriveState::operation_enabled) continue;
          if (!states.empty()) states += ", ";
          states += node_description(drive_node(j)) + " " +
                    (got_feedback[i] ? std::string(state ? to_string(*state) : "unknown state")
                                     : std::string("not answering"));
        }
        fail_start("drives not in operation enabled within " +
                   std::to_string(config.enable_timeout.count()) + " ms: " + states);
      }
      next += config.period;
      sleep_until(next);
    }
    enabling = false;
    publish(true);
  }

  void shutdown() {
    // Brake and switch off cleanly, then leave operational so no RPDO timeout follows.
    window_open = false;
    for (int j = 0; j < kDriveCount; ++j) {
      send(*drive_bus, encode_drive_command(DriveCommand{drive_node(j), controlword::kShutdown, 0.0}));
    }
    sync_counter = next_sync_counter(sync_counter);
    send(*drive_bus, encode_sync(sync_counter));
    if (separate_sensor_bus) send(*separate_sensor_bus, encode_sync(sync_counter));
    send_nmt_all(NmtCommand::enter_pre_operational);
  }
};

// ---- Pa10Master ---------------------------------------------------------------------------

Pa10Master::Pa10Master(std::unique_ptr<Bus> drive_bus, std::unique_ptr<Bus> sensor_bus,
                       MasterConfig config)
    : impl_(std::make_unique<Impl>(std::move(drive_bus), std::move(sensor_bus), std::move(config))) {}

Pa10Master::Pa10Master(std::string_view drive_bus_spec, std::string_view sensor_bus_spec,
                       MasterConfig config)
    : Pa10Master(open_bus(drive_bus_spec),
                 sensor_bus_spec.empty() || sensor_bus_spec == drive_bus_spec ? nullptr
                                                                               : open_bus(sensor_bus_spec),
                 std::move(config)) {}

Pa10Master::~Pa10Master() {
  stop();
  if (impl_->started) {
    try {
      impl_->shutdown();
    } catch (const std::exception&) {
      // The bus is gone: the drives' own RPDO timeout brakes them.
    }
  }
}

void Pa10Master::start() { impl_->start(); }

bool Pa10Master::step() {
  if (running_.load()) throw std::logic_error("Pa10Master::step() while run_periodic() runs");
  if (external_.load()) throw std::logic_error("Pa10Master::step() while its cycles are taken over");
  if (!impl_->started) throw std::logic_error("Pa10Master::step() before start()");
  try {
    return impl_->step();
  } catch (const BusError& e) {
    impl_->bus_failure(e);
    return false;
  }
}

void Pa10Master::run_periodic() {
  if (!impl_->started) throw std::logic_error("Pa10Master::run_periodic() before start()");
  {
    std::lock_guard lock(handover_mutex_);
    if (handover_ != Handover::own) throw std::logic_error("Pa10Master::run_periodic() while its cycles are taken over");
  }
  if (running_.exchange(true)) return;
  thread_ = std::thread([this] {
    Impl& m = *impl_;
    prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);  // default slack wakes ~50 µs late
    if (m.config.cpu >= 0) {
      cpu_set_t cpus;
      CPU_ZERO(&cpus);
      CPU_SET(m.config.cpu, &cpus);
      pthread_setaffinity_np(pthread_self(), sizeof cpus, &cpus);
    }
    if (m.config.realtime_priority > 0) {
      sched_param param{};
      param.sched_priority = m.config.realtime_priority;
      pthread_setschedparam(pthread_self(), SCHED_FIFO, &param);  // best effort: needs rights
    }
    auto next = steady_clock::now();
    publish_deadline(next);
    while (running_.load(std::memory_order_relaxed)) {
      {
        std::lock_guard cycle(cycle_mutex_);
        try {
          m.periodic_cycle();
        } catch (const BusError& e) {
          m.bus_failure(e);
        }
      }
      next += m.config.period;
      const auto now = steady_clock::now();
      if (now >= next) {
        ++m.counters.overruns;
        while (next <= now) next += m.config.period;  // skip, do not burst to catch up
      }
      publish_deadline(next);
      if (!idle_while_taken_over(next)) break;
      sleep_until(next);
    }
  });
}

void Pa10Master::publish_deadline(SteadyTime next) {
  next_cycle_deadline_ns_.store(duration_cast<nanoseconds>(next.time_since_epoch()).count(), std::memory_order_relaxed);
}

// On the periodic thread, between two cycles: when take_over_cycles() asks, idles until the
// cycles are handed back (next becomes the deadline they were handed back with), stop(), or
// the owner falls silent (then takes them back: next is now). False when the thread is to end.
bool Pa10Master::idle_while_taken_over(SteadyTime& next) {
  std::unique_lock lock(handover_mutex_);
  if (handover_ != Handover::requested) return true;
  handover_deadline_ns_ = duration_cast<nanoseconds>(next.time_since_epoch()).count();
  handover_ = Handover::external;
  reclaimed_.store(false);
  external_.store(true, std::memory_order_release);
  next_cycle_deadline_ns_.store(0, std::memory_order_relaxed);
  handover_cv_.notify_all();

  // Watch the owner on the grid: one check per period, from one period after its first cycle.
  const auto period = impl_->config.period;
  std::uint64_t seen = transmits_.load();
  int silent = 0;
  auto check = next + period;
  const auto handed_back = [this] { return handover_ == Handover::returning || !running_.load(); };
  for (;;) {
    if (handover_cv_.wait_until(lock, check, handed_back)) break;
    const auto now = steady_clock::now();
    const std::uint64_t transmits = transmits_.load();
    if (transmits != seen) {
      seen = transmits;
      silent = 0;
    } else if (now - check < period / 2) {
      ++silent;
    } else {
      silent = 0;  // this thread was late too: the process or the host stalled, not the owner alone
    }
    check += period;
    while (check <= now) check += period;
    if (impl_->config.taken_over_timeout_periods <= 0 || silent < impl_->config.taken_over_timeout_periods) continue;
    std::unique_lock cycle(cycle_mutex_, std::try_to_lock);
    if (!cycle.owns_lock()) continue;  // the owner is inside a half cycle: let it finish
    external_.store(false, std::memory_order_release);
    reclaimed_.store(true);
    handover_ = Handover::own;
    impl_->latch_fault(FaultKind::cycle_owner_lost, 0, 0,
                       "the thread running the bus cycles sent no SYNC for %d periods: the master's own thread "
                       "took them back",
                       silent);
    next = now;
    publish_deadline(next);
    return true;
  }
  if (handover_ != Handover::returning) return false;  // stop(): the caller keeps the cycles
  // Back on the grid of the deadline handed back, skipping whole periods already past (the
  // cycle due now, if any, runs at once).
  next = SteadyTime(nanoseconds(handover_deadline_ns_));
  const auto now = steady_clock::now();
  while (next + period <= now) next += period;
  handover_ = Handover::own;
  handover_cv_.notify_all();
  publish_deadline(next);
  return true;
}

std::int64_t Pa10Master::take_over_cycles() {
  if (!impl_->started) throw std::logic_error("Pa10Master::take_over_cycles() before start()");
  std::unique_lock lock(handover_mutex_);
  if (handover_ == Handover::external) return handover_deadline_ns_;
  if (handover_ != Handover::own) throw std::logic_error("Pa10Master::take_over_cycles() from two threads at once");
  handover_ = Handover::requested;
  handover_cv_.wait(lock, [this] { return handover_ == Handover::external || !running_.load(); });
  if (handover_ != Handover::external) {
    // No periodic thread (never started, or stopped meanwhile): nothing to wait for.
    handover_ = Handover::external;
    handover_deadline_ns_ = 0;
    external_.store(true, std::memory_order_release);
  }
  return handover_deadline_ns_;
}

void Pa10Master::hand_back_cycles(std::int64_t next_deadline_ns) {
  std::unique_lock lock(handover_mutex_);
  if (handover_ != Handover::external) return;
  external_.store(false, std::memory_order_release);
  if (!running_.load()) {  // nobody parked: the cycles simply stop being the caller's
    handover_ = Handover::own;
    return;
  }
  handover_deadline_ns_ = next_deadline_ns > 0 ? next_deadline_ns
                                               : duration_cast<nanoseconds>(steady_clock::now().time_since_epoch()).count();
  handover_ = Handover::returning;
  handover_cv_.notify_all();
  handover_cv_.wait(lock, [this] { return handover_ == Handover::own || !running_.load(); });
  handover_ = Handover::own;
}

bool Pa10Master::cycles_taken_over() const { return external_.load(std::memory_order_acquire); }

bool Pa10Master::run_half_cycle(const char* what, void (Impl::*half)()) {
  std::lock_guard cycle(cycle_mutex_);
  if (!external_.load(std::memory_order_acquire)) {
    if (reclaimed_.load()) return false;
    throw std::logic_error(std::string("Pa10Master::") + what + "() without take_over_cycles()");
  }
  try {
    (impl_.get()->*half)();
  } catch (const BusError& e) {
    impl_->bus_failure(e);
  }
  return true;
}

bool Pa10Master::receive_cycle() { return run_half_cycle("receive_cycle", &Impl::periodic_receive); }

bool Pa10Master::transmit_cycle() {
  const bool mine = run_half_cycle("transmit_cycle", &Impl::periodic_transmit);
  if (mine) transmits_.fetch_add(1);
  return mine;
}

void Pa10Master::run_periodic(std::chrono::nanoseconds period) {
  if (period <= nanoseconds(0)) throw std::invalid_argument("Pa10Master::run_periodic: period must be > 0");
  if (running_.load()) throw std::logic_error("Pa10Master::run_periodic(period) while already running");
  impl_->config.period = period;
  run_periodic();
}

void Pa10Master::stop() {
  {
    std::lock_guard lock(handover_mutex_);  // a parked thread or a waiting hand-over sees it
    if (!running_.exchange(false)) return;
    handover_cv_.notify_all();
  }
  if (thread_.joinable()) thread_.join();
  next_cycle_deadline_ns_.store(0, std::memory_order_relaxed);
}

std::int64_t Pa10Master::next_cycle_deadline_ns() const {
  return next_cycle_deadline_ns_.load(std::memory_order_relaxed);
}

std::chrono::nanoseconds Pa10Master::period() const { return impl_->config.period; }

std::uint64_t Pa10Master::target_sequence() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->shared_target_sequence;
}

Pa10Master::SentTarget Pa10Master::last_sent() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->shared_last_sent;
}

std::uint64_t Pa10Master::set_target_velocities(const std::array<double, kDriveCount>& velocity_rad_s) {
  for (int j = 0; j < kDriveCount; ++j) {
    if (!std::isfinite(velocity_rad_s[static_cast<std::size_t>(j)])) {
      throw std::invalid_argument("Pa10Master::set_target_velocities: joint " +
                                  std::string(joint_name(j)) + " velocity is not finite");
    }
  }
  std::lock_guard lock(impl_->mutex);
  if (impl_->shared_fault.kind != FaultKind::none) return 0;
  impl_->shared_target_rad_s = velocity_rad_s;
  impl_->shared_target_valid = true;
  impl_->shared_quick_stop_requested = false;
  return ++impl_->shared_target_sequence;
}

void Pa10Master::quick_stop() {
  std::lock_guard lock(impl_->mutex);
  if (impl_->shared_fault.kind != FaultKind::none) return;
  impl_->shared_quick_stop_requested = true;
  impl_->shared_target_valid = false;
}

bool Pa10Master::quick_stopped() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->shared_quick_stopped;
}

JointState Pa10Master::joint_state() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->shared_state;
}

Wrench Pa10Master::wrench(ForceSensor sensor) const {
  std::lock_guard lock(impl_->mutex);
  return impl_->shared_wrench[sensor_slot(sensor)];
}

MasterFault Pa10Master::fault() const {
  FaultRecord record;
  {
    std::lock_guard lock(impl_->mutex);
    record = impl_->shared_fault;
  }
  return MasterFault{record.kind, record.node, record.code, std::string(record.reason.data())};
}

bool Pa10Master::enabled() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->shared_enabled;
}

void Pa10Master::fault_reset() {
  std::lock_guard lock(impl_->mutex);
  impl_->shared_reset_requested = true;
  impl_->shared_target_valid = false;
  impl_->shared_quick_stop_requested = false;
}

MasterCounters Pa10Master::counters() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->shared_counters;
}

const std::string& Pa10Master::drive_bus_name() const { return impl_->drive_bus->name(); }
const std::string& Pa10Master::sensor_bus_name() const { return impl_->sensor_bus->name(); }

}  // namespace rtm::can
