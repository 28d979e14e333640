// SPDX-License-Identifier: Apache-2.0
#include "sim/runner.h"

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "arm/can/bus.h"
#include "arm/can/local_bus.h"
#include "rt/background_writer.h"
#include "rt/clock.h"
#include "rt/schedule.h"
#include "rt/thread.h"
#include "sim/bus_sink.h"
#include "sim/simulator.h"

namespace rtm::sim {

namespace {

constexpr std::int64_t kWallHeartbeatPeriod_ns = 100'000'000;
// A real-time step found later than this is not caught up (no burst after a host stall).
constexpr std::int64_t kMaxCatchUp_ns = 20'000'000;

// Opens `spec`; for "local:<path>" with no hub listening, starts one in this process.
std::unique_ptr<rtm::can::Bus> open_or_host(const std::string& spec,
                                            std::unique_ptr<rtm::can::LocalHub>& hub) {
  constexpr std::string_view kLocal = "local:";
  if (spec.rfind(kLocal, 0) != 0) return rtm::can::open_bus(spec);
  const std::string path = spec.substr(kLocal.size());
  try {
    return rtm::can::open_bus(spec);
  } catch (const rtm::can::BusError&) {
    if (path.empty()) throw;
  }
  // Nobody listens there: host the bus. Its poll rounds run in the simulator's own loop
  // (run_simulator), so a bus round wakes one thread here, not the hub's and then the loop.
  hub = std::make_unique<rtm::can::LocalHub>(path, rtm::can::LocalHub::Driver::caller);
  return rtm::can::open_bus(spec);
}

// CSV of the state after each SYNC. Rows are formatted in the loop into a fixed buffer and
// written by a thread of their own (rtm::BackgroundWriter): the loop never calls write() nor
// waits for the disk; rows it could not hand over (the disk stalled for a whole buffer) are
// dropped and counted in the summary.
class CsvLog {
 public:
  explicit CsvLog(const std::string& path) {
    if (path.empty()) return;
    try {
      writer_ = std::make_unique<BackgroundWriter>(path);
    } catch (const std::runtime_error& e) {
      throw RunError(std::string("--log ") + e.what());
    }
    std::string header = "time_s";
    for (const char* j : {"s1", "s2", "s3", "e1", "e2", "w1", "w2"}) header += std::string(",q_") + j + "_rad";
    for (const char* j : {"s1", "s2", "s3", "e1", "e2", "w1", "w2"}) header += std::string(",qd_") + j + "_rad_s";
    header += ",tool_x_m,tool_y_m,tool_z_m,wrist_fx_N,wrist_fy_N,wrist_fz_N,wrist_tx_Nm,"
              "wrist_ty_Nm,wrist_tz_Nm,joy_fx_N,joy_fy_N,joy_fz_N,joy_tx_Nm,joy_ty_Nm,"
              "joy_tz_Nm\n";
    writer_->append(header);
  }

  void row(Pa10Simulator& sim) {
    if (!writer_) return;
    Pa10Plant& plant = sim.plant();
    used_ = 0;
    add(static_cast<double>(sim.time_ns()) * 1e-9, 4, false);
    for (int j = 0; j < kJointCount; ++j) add(plant.joint_state(j).position_rad, 6);
    for (int j = 0; j < kJointCount; ++j) add(plant.joint_state(j).velocity_rad_s, 6);
    for (double p : plant.tool_position_m()) add(p, 6);
    add_wrench(plant.wrist_wrench(), sim.wrist_sensor().offset());
    add_wrench(plant.joystick_wrench(), sim.joystick_sensor().offset());
    line_[used_++] = '\n';  // add() leaves room for it
    writer_->append(std::string_view(line_, used_));
  }

  std::uint64_t dropped_rows() const { return writer_ ? writer_->dropped() : 0; }

 private:
  // Appends one number with `decimals` digits after the point (as "%.<decimals>f"), after a
  // comma unless it is the row's first, to the row: a fixed buffer, no allocation, and
  // std::to_chars (a few times cheaper than snprintf; 30 numbers a row, 500 rows a second).
  void add(double value, int decimals, bool comma = true) {
    char* const end = line_ + sizeof line_ - 1;  // one byte kept for the newline
    char* at = line_ + used_;
    if (comma && at < end) *at++ = ',';
    const auto [next, error] = std::to_chars(at, end, value, std::chars_format::fixed, decimals);
    if (error == std::errc{}) used_ = static_cast<std::size_t>(next - line_);
  }
  void add_wrench(const Wrench& raw, const Wrench& offset) {
    for (int i = 0; i < 3; ++i) add(raw.force_N[i] - offset.force_N[i], 3);
    for (int i = 0; i < 3; ++i) add(raw.torque_Nm[i] - offset.torque_Nm[i], 4);
  }

  std::unique_ptr<BackgroundWriter> writer_;
  char line_[1024] = {};
  std::size_t used_ = 0;
};

// Non-blocking line reader for stdin wrench commands.
class StdinWrench {
 public:
  explicit StdinWrench(bool enabled) : enabled_(enabled) {
    if (enabled_) fcntl(STDIN_FILENO, F_SETFL, fcntl(STDIN_FILENO, F_GETFL) | O_NONBLOCK);
  }
  int fd() const { return enabled_ ? STDIN_FILENO : -1; }

  // Reads what is available; applies each complete valid line to `sim`. A bad line is
  // reported on stderr and ignored (the operator retypes it).
  void read_into(Pa10Simulator& sim) {
    char chunk[512];
    for (;;) {
      const ssize_t n = ::read(STDIN_FILENO, chunk, sizeof chunk);
      if (n == 0) {  // EOF: keep the last wrench
        enabled_ = false;
        return;
      }
      if (n < 0) return;
      pending_.append(chunk, static_cast<std::size_t>(n));
      std::size_t newline = 0;
      while ((newline = pending_.find('\n')) != std::string::npos) {
        const std::string line = pending_.substr(0, newline);
        pending_.erase(0, newline + 1);
        try {
          Wrench wrench;
          if (parse_wrench_line(line, wrench)) sim.set_operator_override(wrench);
        } catch (const ProfileError& error) {
          std::fprintf(stderr, "pa10-sim: ignored: %s\n", error.what());
        }
      }
    }
  }

 private:
  bool enabled_;
  std::string pending_;
};

// The simulator's configuration from the command line; RunError on a bad value.
SimulatorConfig simulator_config(const RunOptions& options) {
  if (!std::filesystem::is_regular_file(options.scene_path))
    throw RunError(options.scene_path + ": scene file not found");
  SimulatorConfig config;
  config.scene_path = options.scene_path;
  if (!(options.velocity_bandwidth_rad_s > 0 && options.velocity_bandwidth_rad_s <= 500))
    throw RunError("--velocity-bandwidth must be in (0, 500] rad/s");
  config.gains.velocity_bandwidth_rad_s = options.velocity_bandwidth_rad_s;
  try {
    config.surface = parse_surface(options.surface);
    config.surface.friction = options.friction;
  } catch (const std::invalid_argument& error) {
    throw RunError(std::string("--surface: ") + error.what());
  }
  if (!(options.friction >= 0 && options.friction <= 2)) throw RunError("--friction must be in [0, 2]");
  if (!options.profile_path.empty())
    config.operator_profile = OperatorProfile::from_file(options.profile_path);
  return config;
}

void print_ready(const rtm::can::Bus& bus, const rtm::can::Bus* sensor_bus, bool lock_step,
                 const Surface& surface) {
  std::printf("pa10-sim: ready on %s%s%s (%s; surface %s, %.0f N/m)\n", bus.name().c_str(),
              sensor_bus ? ", sensors on " : "", sensor_bus ? sensor_bus->name().c_str() : "",
              lock_step ? "lock-step" : "real time", surface.name.c_str(), surface.stiffness_N_m);
  std::fflush(stdout);
}

// What pa10-sim prints when it stops.
void print_summary(Pa10Simulator& sim, std::uint64_t dropped, const PeriodicSchedule* schedule) {
  std::printf("pa10-sim: stopped at sim time %.3f s after %llu steps; %llu frames dropped "
              "(transmit queue full)\n",
              static_cast<double>(sim.time_ns()) * 1e-9, static_cast<unsigned long long>(sim.steps()),
              static_cast<unsigned long long>(dropped));
  if (schedule) {
    const ActivityStats stats = schedule->stats();
    std::printf("pa10-sim: step start lateness p50 %.2f ms, p99 %.2f ms, max %.2f ms; %llu steps "
                "more than one step late; %llu steps skipped after host stalls (%.1f ms of sim "
                "time not simulated)\n",
                static_cast<double>(stats.lateness_p50_ns) * 1e-6,
                static_cast<double>(stats.lateness_p99_ns) * 1e-6,
                static_cast<double>(stats.lateness_max_ns) * 1e-6,
                static_cast<unsigned long long>(stats.overruns),
                static_cast<unsigned long long>(stats.skipped),
                static_cast<double>(stats.skipped) * static_cast<double>(stats.period_ns) * 1e-6);
  }
  std::fflush(stdout);
}

// The loop's one ppoll: over its bus endpoints, stdin and the sockets of the hubs it hosts
// (LocalHub::Driver::caller). The hubs relay their round right after it; frames they hand to
// this process's own endpoints are there then, and read in the same round, not after another
// poll. The set is made again each round (endpoints come and go); its capacity once.
class LoopPoll {
 public:
  LoopPoll(rtm::can::Bus& bus, rtm::can::Bus* sensor_bus, rtm::can::LocalHub* hub, rtm::can::LocalHub* sensor_hub,
           const StdinWrench& in)
      : bus_(bus), sensor_bus_(sensor_bus), hub_(hub), sensor_hub_(sensor_hub), in_(in) {
    fds_.reserve(3 + 2 * (rtm::can::LocalHub::kMaxEndpoints + 1));
  }

  // Waits at most timeout for any of them, then relays the hubs' rounds. Throws RunError
  // when ppoll fails.
  void wait(const timespec& timeout) {
    fds_.clear();
    fds_.push_back({bus_.pollable_fd(), POLLIN, 0});
    fds_.push_back({sensor_bus_ ? sensor_bus_->pollable_fd() : -1, POLLIN, 0});
    fds_.push_back({in_.fd(), POLLIN, 0});
    const std::size_t hub_at = fds_.size();
    if (hub_) hub_->add_poll_fds(fds_);
    const std::size_t sensor_hub_at = fds_.size();
    if (sensor_hub_) sensor_hub_->add_poll_fds(fds_);
    const int ready = ppoll(fds_.data(), fds_.size(), &timeout, nullptr);
    if (ready < 0 && errno != EINTR)
      throw RunError(std::string("pa10-sim: ppoll failed: ") + std::strerror(errno));
    relayed_ = sensor_relayed_ = false;
    if (ready <= 0) return;  // revents: still the 0 they were made with
    const std::span<const pollfd> polled(fds_);
    relayed_ = hub_ && hub_->relay(polled.subspan(hub_at, sensor_hub_at - hub_at)) > 0;
    sensor_relayed_ = sensor_hub_ && sensor_hub_->relay(polled.subspan(sensor_hub_at)) > 0;
  }
  bool bus_ready() const { return fds_[0].revents != 0 || relayed_; }
  bool sensor_bus_ready() const { return sensor_bus_ && (fds_[1].revents != 0 || sensor_relayed_); }
  bool stdin_ready() const { return fds_[2].revents != 0; }

 private:
  rtm::can::Bus& bus_;
  rtm::can::Bus* sensor_bus_;
  rtm::can::LocalHub* hub_;
  rtm::can::LocalHub* sensor_hub_;
  const StdinWrench& in_;
  std::vector<pollfd> fds_;
  bool relayed_ = false, sensor_relayed_ = false;
};

}  // namespace

void run_simulator(const RunOptions& options, const std::atomic<bool>& stop) {
  Pa10Simulator sim(simulator_config(options));
  sim.set_mode(options.lock_step ? Pa10Simulator::Mode::lock_step
                                 : Pa10Simulator::Mode::real_time);

  std::unique_ptr<rtm::can::LocalHub> hub;
  std::unique_ptr<rtm::can::LocalHub> sensor_hub;
  auto bus = open_or_host(options.buses.bus, hub);
  BusSink sink(*bus);
  std::unique_ptr<rtm::can::Bus> sensor_bus;
  std::unique_ptr<BusSink> sensor_sink;
  if (options.buses.sensors() != options.buses.bus) {
    sensor_bus = open_or_host(options.buses.sensor_bus, sensor_hub);
    sensor_sink = std::make_unique<BusSink>(*sensor_bus);
    sim.set_sensor_sink(sensor_sink.get());
  }
  CsvLog log(options.log_path);
  StdinWrench stdin_wrench(options.stdin_wrench);

  apply_thread_settings(ThreadSettings{"pa10-sim"});  // timer slack 1 ns: 50 us would blur 1 ms steps
  sim.power_on(sink);
  if (!options.quiet) print_ready(*bus, sensor_bus.get(), options.lock_step, sim.plant().surface());

  const std::int64_t duration_ns = static_cast<std::int64_t>(options.duration_s * 1e9);
  const std::int64_t timestep_ns = std::llround(sim.plant().timestep_s() * 1e9);
  // The physics steps on the project's periodic schedule; only the wait differs from an
  // activity's: ppoll, so frames are answered between steps.
  PeriodicSchedule schedule(timestep_ns, kMaxCatchUp_ns);
  schedule.start(monotonic_ns() + timestep_ns, monotonic_ns());
  std::int64_t next_wall_beat_ns = monotonic_ns() + kWallHeartbeatPeriod_ns;
  std::uint64_t last_logged_sync = sim.drive(0).syncs_seen();

  LoopPoll poll(*bus, sensor_bus.get(), hub.get(), sensor_hub.get(), stdin_wrench);
  can_frame frame{};
  while (!stop.load(std::memory_order_relaxed)) {
    // What the last round's frames and steps made the nodes send leaves now, in one batch.
    sink.flush();
    if (sensor_sink) sensor_sink->flush();
    if (duration_ns > 0 && sim.time_ns() >= duration_ns) break;
    const std::int64_t now_ns = monotonic_ns();
    const std::int64_t wake_ns = options.lock_step ? next_wall_beat_ns : schedule.deadline_ns();
    const timespec timeout = to_timespec(std::max<std::int64_t>(0, wake_ns - now_ns));
    poll.wait(timeout);
    if (poll.bus_ready())
      while (bus->receive(frame, 0)) sim.on_frame(frame, sink);
    if (poll.sensor_bus_ready())
      while (sensor_bus->receive(frame, 0)) sim.on_sensor_bus_frame(frame);
    if (poll.stdin_ready()) stdin_wrench.read_into(sim);
    if (sim.drive(0).syncs_seen() != last_logged_sync) {
      last_logged_sync = sim.drive(0).syncs_seen();
      log.row(sim);
    }
    const std::int64_t after_ns = monotonic_ns();
    if (options.lock_step) {
      if (after_ns >= next_wall_beat_ns) {
        sim.send_heartbeats(sink);
        next_wall_beat_ns = after_ns + kWallHeartbeatPeriod_ns;
      }
      continue;
    }
    while (after_ns >= schedule.deadline_ns()) {
      schedule.begin(after_ns);
      sim.step(sink);
      schedule.end(after_ns);  // a stall longer than kMaxCatchUp_ns is skipped, not caught up
    }
  }
  if (!options.quiet)
    print_summary(sim, sink.dropped() + (sensor_sink ? sensor_sink->dropped() : 0),
                  options.lock_step ? nullptr : &schedule);
  if (const std::uint64_t lost = log.dropped_rows(); lost > 0)
    std::fprintf(stderr, "pa10-sim: --log %s: %llu rows dropped (the disk kept the writer busy for a whole buffer)\n",
                 options.log_path.c_str(), static_cast<unsigned long long>(lost));
}

}  // namespace rtm::sim
