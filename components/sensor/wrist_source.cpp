#include "components/sensor/wrist_source.h"

#include "arm/can/protocol.h"

#include <chrono>
#include <vector>

namespace rtm::comp {

namespace pc = rtm::can;

WristSample MasterWristSource::latest() const {
  WristSample sample;
  const pc::Wrench wrench = master_.wrench(pc::ForceSensor::wrist);
  const pc::JointState joints = master_.joint_state();
  sample.wrench_sensor = wrench.values;
  for (std::size_t i = 0; i < sample.q_rad.size(); ++i) sample.q_rad[i] = joints.position_rad[i];
  sample.sequence = wrench.sequence;
  sample.valid = wrench.valid && joints.sync_counter != 0;
  return sample;
}

JointStateListener::JointStateListener(std::string_view bus_spec) {
  std::vector<pc::FrameFilter> filters;
  for (int joint = 0; joint < pc::kDriveCount; ++joint)
    filters.push_back({pc::cob::kTpdo1Base + pc::drive_node(joint), CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG});
  bus_ = pc::open_bus(bus_spec, filters);
  thread_ = std::thread([this] { run(); });
}

JointStateListener::~JointStateListener() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
}

JointStateListener::State JointStateListener::latest() const {
  std::lock_guard lock(mu_);
  return state_;
}

std::string JointStateListener::fault() const {
  std::lock_guard lock(mu_);
  return bus_error_;
}

void JointStateListener::run() {
  using namespace std::chrono_literals;
  while (!stop_.load()) {
    can_frame frame{};
    try {
      if (!bus_->receive(frame, 50'000'000)) continue;
    } catch (const pc::BusError& e) {
      std::lock_guard lock(mu_);
      bus_error_ = std::string("joint state listener: ") + e.what();
      return;
    }
    const auto feedback = pc::decode_drive_feedback(frame);
    if (!feedback.ok()) continue;
    const int joint = pc::joint_index_of(feedback->drive);
    std::lock_guard lock(mu_);
    state_.position_rad[static_cast<std::size_t>(joint)] = feedback->position_rad;
    state_.velocity_rad_s[static_cast<std::size_t>(joint)] = feedback->velocity_rad_s;
    ++state_.frames;
    seen_mask_ = static_cast<std::uint8_t>(seen_mask_ | (1u << joint));
    state_.complete = seen_mask_ == (1u << pc::kDriveCount) - 1;
  }
}

BusWristSource::BusWristSource(std::string_view drive_bus_spec, std::string_view sensor_bus_spec)
    : wrench_(sensor_bus_spec.empty() ? drive_bus_spec : sensor_bus_spec, pc::ForceSensor::wrist),
      joints_(drive_bus_spec) {
  wrench_.start();
}

WristSample BusWristSource::latest() const {
  WristSample sample;
  const pc::Wrench wrench = wrench_.latest();
  const JointStateListener::State joints = joints_.latest();
  sample.wrench_sensor = wrench.values;
  sample.q_rad = joints.position_rad;
  sample.sequence = wrench.sequence;
  sample.valid = wrench.valid && joints.complete;
  return sample;
}

std::string BusWristSource::fault() const {
  std::string why = wrench_.fault();
  if (why.empty()) why = joints_.fault();
  return why;
}

}  // namespace rtm::comp
