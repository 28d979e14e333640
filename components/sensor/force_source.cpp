// SPDX-License-Identifier: Apache-2.0
#include "components/sensor/force_source.h"

namespace rtm::comp {

namespace pc = rtm::can;

ForceSample MasterForceSource::latest() const {
  ForceSample sample;
  const pc::Wrench wrench = master_.wrench(node_);
  const pc::JointState joints = master_.joint_state();
  sample.wrench_sensor = wrench.values;
  for (std::size_t i = 0; i < sample.q_rad.size(); ++i) sample.q_rad[i] = joints.position_rad[i];
  sample.sequence = wrench.sequence;
  sample.valid = wrench.valid;
  sample.q_valid = joints.sync_counter != 0;
  return sample;
}

Fault MasterForceSource::fault() const {
  const pc::MasterFault f = master_.fault();
  if (!f.active() || f.node != pc::sensor_node(node_)) return {};
  if (f.kind == pc::FaultKind::heartbeat_lost || f.kind == pc::FaultKind::emergency) return f;
  return {};  // about this node, but the bus's or the master's business (spoofing, NMT state)
}

BusForceSource::BusForceSource(std::string_view sensor_bus_spec, pc::ForceSensor node, std::string_view drive_bus_spec,
                               std::int64_t heartbeat_timeout_ns, const rtm::Clock& clock)
    : wrench_(sensor_bus_spec, node, heartbeat_timeout_ns, clock) {
  if (!drive_bus_spec.empty()) joints_.emplace(drive_bus_spec);
  wrench_.start();
  if (joints_) joints_->start();
}

ForceSample BusForceSource::latest() const {
  ForceSample sample;
  // Once every drive has answered a SYNC, each joint has a position: a drive that misses a
  // later SYNC leaves its last one. Asked before the state, so the state has them all.
  const bool every_joint_heard = joints_ && joints_->counters().complete_syncs > 0;
  const pc::Wrench wrench = wrench_.latest();
  sample.wrench_sensor = wrench.values;
  if (joints_) sample.q_rad = joints_->latest().position_rad;
  sample.sequence = wrench.sequence;
  sample.valid = wrench.valid;
  sample.q_valid = every_joint_heard;
  return sample;
}

namespace {

// The listener's kinds as the source reports them: anything but a heartbeat loss and the
// sensor's own EMCY is the bus's.
FaultKind source_kind(FaultKind kind) {
  if (kind == FaultKind::none || kind == FaultKind::heartbeat_lost || kind == FaultKind::emergency) return kind;
  return FaultKind::bus_error;
}

}  // namespace

FaultKind BusForceSource::fault_kind() const {
  const FaultKind kind = source_kind(wrench_.fault_kind());
  if (kind != FaultKind::none || !joints_) return kind;
  // The joint listener's only fault is a lost bus. Its text is "" (no allocation) without one.
  return joints_->fault_kind();
}

Fault BusForceSource::fault() const {
  const Fault wrench_fault = wrench_.fault();
  const Fault f{source_kind(wrench_fault.kind), wrench_fault.node, wrench_fault.code, wrench_fault.reason};
  return f.active() || !joints_ ? f : joints_->fault();
}

}  // namespace rtm::comp
