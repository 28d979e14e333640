#include "components/sensor/wrist_source.h"

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

BusWristSource::BusWristSource(std::string_view drive_bus_spec, std::string_view sensor_bus_spec)
    : wrench_(sensor_bus_spec.empty() ? drive_bus_spec : sensor_bus_spec, pc::ForceSensor::wrist),
      joints_(drive_bus_spec) {
  wrench_.start();
  joints_.start();
}

WristSample BusWristSource::latest() const {
  WristSample sample;
  // Once every drive has answered a SYNC, each joint has a position: a drive that misses a
  // later SYNC leaves its last one. Asked before the state, so the state has them all.
  const bool every_joint_heard = joints_.counters().complete_syncs > 0;
  const pc::Wrench wrench = wrench_.latest();
  const pc::JointState joints = joints_.latest();
  sample.wrench_sensor = wrench.values;
  sample.q_rad = joints.position_rad;
  sample.sequence = wrench.sequence;
  sample.valid = wrench.valid && every_joint_heard;
  return sample;
}

std::string BusWristSource::fault() const {
  std::string why = wrench_.fault();
  if (why.empty()) why = joints_.fault();
  return why;
}

}  // namespace rtm::comp
