// SPDX-License-Identifier: Apache-2.0
// The one fake of the arm seam (arm/pa10/velocity_arm.h) that tests and benchmarks put behind an
// actuator: it records what it was told and answers what the test set (its fault, its pose).
#pragma once

#include "arm/pa10/velocity_arm.h"

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace rtm_test {

class RecordingArm final : public rtm::pa10::VelocityArm {
 public:
  using SentCommand = rtm::pa10::ArmDiagnostics::SentCommand;
  RecordingArm() : VelocityArm(diagnostics_) {}

  // One entry per order: the twist ordered, or zero with braked set for a quick stop.
  std::vector<std::array<float, 6>> ordered;
  std::vector<bool> braked;
  int stops = 0;
  int resets = 0;
  // What the arm answers each order, and its fault: status latched until reset().
  rtm::pa10::FaultKind status = rtm::pa10::FaultKind::none;
  std::uint8_t fault_node = 0;
  std::string reason;
  // Called at each order and quick stop before it is recorded (a test may throw from it, as
  // an arm whose bus went away would).
  std::function<void()> on_order;
  // A bus master in miniature: each ready order is target sequence n; the test says when the
  // bus "sent" which one.
  std::uint64_t sequence = 0;
  SentCommand sent{};
  // What measured_tool_pose() answers: none (the arm cannot tell) until the test sets one. Each
  // read is counted, with the number of orders (and quick stops) made before it.
  std::optional<std::array<double, 6>> pose;
  int pose_reads = 0;
  std::size_t orders_before_pose_read = 0;

  rtm::pa10::FaultKind order_velocity(const std::array<float, 6>& twist) override {
    if (on_order) on_order();
    if (status == rtm::pa10::FaultKind::none) ++sequence;
    ordered.push_back(twist);
    braked.push_back(false);
    return status;
  }
  rtm::pa10::FaultKind quick_stop() override {
    if (on_order) on_order();
    ordered.push_back({});
    braked.push_back(true);
    return status;
  }
  void stop() override { ++stops; }
  rtm::pa10::ArmFault fault() const override {
    if (!rtm::can::latched(status)) return {status, 0, 0, ""};
    return {status, fault_node, 0, reason};
  }
  void reset() override {
    ++resets;
    status = rtm::pa10::FaultKind::none;
  }
  bool measured_tool_pose(std::array<double, 6>& out) override {
    ++pose_reads;
    orders_before_pose_read = ordered.size();
    if (!pose) return false;
    out = *pose;
    return true;
  }

 private:
  // What the bus "says": the sequence handed out and the one the test says was sent.
  class Diagnostics final : public rtm::pa10::ArmDiagnostics {
   public:
    explicit Diagnostics(const RecordingArm& arm) : arm_(arm) {}
    std::uint64_t command_sequence() const override { return arm_.sequence; }
    SentCommand last_sent() const override { return arm_.sent; }

   private:
    const RecordingArm& arm_;
  };
  Diagnostics diagnostics_{*this};
};

}  // namespace rtm_test
