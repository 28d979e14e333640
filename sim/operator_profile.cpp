// SPDX-License-Identifier: Apache-2.0
#include "sim/operator_profile.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <sstream>

namespace rtm::sim {

namespace {

[[noreturn]] void fail(const std::string& source, const std::string& where,
                       const std::string& what) {
  throw ProfileError(source + ": " + where + ": " + what);
}

double finite_number(const YAML::Node& node, const std::string& source, const std::string& where) {
  double value = 0;
  try {
    value = node.as<double>();
  } catch (const YAML::Exception&) {
    fail(source, where, "expected a number, got '" + YAML::Dump(node) + "'");
  }
  if (!std::isfinite(value)) fail(source, where, "value is not finite");
  return value;
}

void read_vector3(const YAML::Node& node, std::array<double, 3>& out, const std::string& source,
                  const std::string& where) {
  if (!node.IsSequence() || node.size() != 3) fail(source, where, "expected a list of 3 numbers");
  for (std::size_t i = 0; i < 3; ++i) out[i] = finite_number(node[i], source, where);
}

// step/ramp body: {force_N: [..], torque_Nm: [..]} (+ duration_s for a ramp); an omitted
// vector keeps the current value.
void read_wrench(const YAML::Node& body, Wrench& wrench, const std::string& source,
                 const std::string& where) {
  if (!body.IsMap()) fail(source, where, "expected a map with force_N and/or torque_Nm");
  for (const auto& entry : body) {
    const auto key = entry.first.as<std::string>();
    if (key == "force_N") {
      read_vector3(entry.second, wrench.force_N, source, where + ".force_N");
    } else if (key == "torque_Nm") {
      read_vector3(entry.second, wrench.torque_Nm, source, where + ".torque_Nm");
    } else if (key != "duration_s") {
      fail(source, where, "unknown key '" + key + "' (force_N, torque_Nm, duration_s)");
    }
  }
}

}  // namespace

OperatorProfile OperatorProfile::from_file(const std::string& path) {
  std::ifstream file(path);
  if (!file) throw ProfileError(path + ": cannot open the operator profile");
  std::stringstream text;
  text << file.rdbuf();
  return from_yaml(text.str(), path);
}

OperatorProfile OperatorProfile::from_yaml(const std::string& yaml_text,
                                           const std::string& source) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& error) {
    throw ProfileError(source + ": not valid YAML: " + error.what());
  }
  if (!root.IsMap()) fail(source, "top level", "expected a map with 'segments'");
  OperatorProfile profile;
  for (const auto& entry : root) {
    const auto key = entry.first.as<std::string>();
    if (key != "segments" && key != "repeat")
      fail(source, "top level", "unknown key '" + key + "' (segments, repeat)");
  }
  if (const auto repeat = root["repeat"]) {
    try {
      profile.repeat_ = repeat.as<bool>();
    } catch (const YAML::Exception&) {
      fail(source, "repeat", "expected true or false");
    }
  }
  const YAML::Node segments = root["segments"];
  if (!segments || !segments.IsSequence() || segments.size() == 0)
    fail(source, "segments", "expected a non-empty list of hold/step/ramp segments");

  Wrench current{};
  double time_s = 0;
  profile.knots_.push_back({0.0, current, false});
  for (std::size_t i = 0; i < segments.size(); ++i) {
    const YAML::Node segment = segments[i];
    const std::string where = "segment " + std::to_string(i + 1);
    if (!segment.IsMap() || segment.size() != 1)
      fail(source, where, "expected exactly one of 'hold: <s>', 'step: {...}', 'ramp: {...}'");
    const auto kind = segment.begin()->first.as<std::string>();
    const YAML::Node body = segment.begin()->second;
    if (kind == "hold") {
      const double duration_s = finite_number(body, source, where + ".hold");
      if (duration_s <= 0) fail(source, where, "hold duration must be > 0 s");
      time_s += duration_s;
      profile.knots_.push_back({time_s, current, false});
    } else if (kind == "step") {
      read_wrench(body, current, source, where + ".step");
      if (body["duration_s"]) fail(source, where, "a step has no duration_s (use hold after it)");
      profile.knots_.push_back({time_s, current, false});
    } else if (kind == "ramp") {
      read_wrench(body, current, source, where + ".ramp");
      if (!body["duration_s"]) fail(source, where, "a ramp needs duration_s");
      const double duration_s = finite_number(body["duration_s"], source, where + ".duration_s");
      if (duration_s <= 0) fail(source, where, "ramp duration must be > 0 s");
      time_s += duration_s;
      profile.knots_.push_back({time_s, current, true});
    } else {
      fail(source, where, "unknown segment '" + kind + "' (hold, step, ramp)");
    }
  }
  if (profile.repeat_ && time_s <= 0)
    fail(source, "repeat", "a repeating profile needs a total duration > 0 s");
  return profile;
}

Wrench OperatorProfile::wrench_at(double t_s) const {
  if (knots_.empty() || !(t_s >= 0)) return {};
  const double total_s = knots_.back().time_s;
  if (repeat_ && total_s > 0) t_s = std::fmod(t_s, total_s);
  // The last knot at or before t_s decides, unless the next one ramps towards it.
  std::size_t next = 0;
  while (next < knots_.size() && knots_[next].time_s <= t_s) ++next;
  if (next == knots_.size()) return knots_.back().wrench;
  const Knot& before = knots_[next - 1];  // next >= 1: knots_[0].time_s == 0 <= t_s
  const Knot& after = knots_[next];
  if (!after.ramp) return before.wrench;
  const double fraction = (t_s - before.time_s) / (after.time_s - before.time_s);
  Wrench wrench;
  for (int i = 0; i < 3; ++i) {
    wrench.force_N[i] = before.wrench.force_N[i] +
                        fraction * (after.wrench.force_N[i] - before.wrench.force_N[i]);
    wrench.torque_Nm[i] = before.wrench.torque_Nm[i] +
                          fraction * (after.wrench.torque_Nm[i] - before.wrench.torque_Nm[i]);
  }
  return wrench;
}

bool parse_wrench_line(const std::string& line, Wrench& wrench) {
  std::istringstream in(line);
  std::string first;
  if (!(in >> first) || first[0] == '#') return false;
  in.clear();
  in.str(line);
  double values[6] = {0, 0, 0, 0, 0, 0};
  int count = 0;
  std::string token;
  while (in >> token) {
    if (count == 6) throw ProfileError("stdin: '" + line + "': more than 6 numbers");
    std::size_t used = 0;
    try {
      values[count] = std::stod(token, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != token.size() || !std::isfinite(values[count]))
      throw ProfileError("stdin: '" + line + "': '" + token + "' is not a finite number");
    ++count;
  }
  if (count != 3 && count != 6)
    throw ProfileError("stdin: '" + line + "': expected 'fx fy fz' or 'fx fy fz tx ty tz'");
  for (int i = 0; i < 3; ++i) {
    wrench.force_N[i] = values[i];
    wrench.torque_Nm[i] = values[3 + i];
  }
  return true;
}

}  // namespace rtm::sim
