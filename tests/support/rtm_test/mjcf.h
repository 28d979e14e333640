// SPDX-License-Identifier: Apache-2.0
// Small MuJoCo scenes written inline, as MuJoCo's tests write theirs: a chain of seven light
// links with every name the simulator's plant looks for (sim/pa10_plant.h), whose loads a test
// can work out by hand, instead of the PA10 scene.
//
//   rtm_test::MjcfScene scene;
//   scene.joints[1].axis = {1, 0, 0};
//   scene.joints[1].ready_rad = std::numbers::pi / 2;   // s2 lays the chain down
//   const rtm_test::SceneFile file(rtm_test::plant_scene_mjcf(scene));
//   rtm::sim::Pa10Plant plant(file.path());
#pragma once

#include <unistd.h>

#include <array>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace rtm_test {

// One joint of the chain and the link after it: the link runs along the joint's z from the
// joint to the next one, its mass at its middle.
struct MjcfJoint {
  std::array<double, 3> axis{0, 0, 1};
  double length_m = 0.1;
  double mass_kg = 1.0;
  double ready_rad = 0;  // its position in the keyframe "ready"
  double torque_limit_Nm = 100;
};

struct MjcfScene {
  std::vector<MjcfJoint> joints = std::vector<MjcfJoint>(7);  // s1 s2 s3 e1 e2 w1 w2
  // The tool on the last link: the wrist sensor's site is its origin, tool_tip its far end,
  // 2 * tool_com_m along its z.
  double tool_mass_kg = 0.1;
  double tool_com_m = 0.05;
  double handle_mass_kg = 0.2;  // the joystick's handle, on a fixed post
  // A name the plant looks for, written "x_<name>" wherever it stands (and in what refers to
  // it), so that the scene still loads but lacks it. "" for none.
  std::string renamed;
};

// The scene's MJCF text.
inline std::string plant_scene_mjcf(const MjcfScene& scene) {
  static const char* const kNames[] = {"s1", "s2", "s3", "e1", "e2", "w1", "w2"};
  if (scene.joints.size() != 7) throw std::invalid_argument("plant_scene_mjcf: the plant drives 7 joints");
  const auto name = [&](const std::string& n) { return n == scene.renamed ? "x_" + n : n; };
  const auto inertial = [](double z_m, double mass_kg) {
    std::ostringstream out;
    out.precision(17);
    out << "<inertial pos=\"0 0 " << z_m << "\" mass=\"" << mass_kg << "\" diaginertia=\"1e-4 1e-4 1e-4\"/>";
    return out.str();
  };
  std::ostringstream out;
  out.precision(17);
  out << "<mujoco model=\"inline\">\n  <compiler angle=\"radian\" autolimits=\"true\" inertiafromgeom=\"false\"/>\n"
         "  <option timestep=\"0.001\" integrator=\"Euler\" gravity=\"0 0 -9.81\"/>\n  <worldbody>\n";
  double previous_length_m = 0;
  for (std::size_t i = 0; i < 7; ++i) {
    const MjcfJoint& j = scene.joints[i];
    out << "<body name=\"link" << i + 1 << "\" pos=\"0 0 " << previous_length_m << "\">"
        << inertial(j.length_m / 2, j.mass_kg) << "<joint name=\"" << name(kNames[i]) << "\" axis=\"" << j.axis[0]
        << ' ' << j.axis[1] << ' ' << j.axis[2] << "\"/>\n";
    previous_length_m = j.length_m;
  }
  out << "<body name=\"tool0\" pos=\"0 0 " << previous_length_m << "\">"
      << inertial(scene.tool_com_m, scene.tool_mass_kg) << "<site name=\"" << name("wrist_ft")
      << "\"/><site name=\"" << name("tool_tip") << "\" pos=\"0 0 " << 2 * scene.tool_com_m << "\"/></body>\n";
  for (int i = 0; i < 7; ++i) out << "</body>";
  out << "\n<body name=\"joystick_post\" pos=\"0 -0.8 0.9\"><body name=\"" << name("joystick_handle")
      << "\" pos=\"0 0 0.05\">" << inertial(0.05, scene.handle_mass_kg) << "<site name=\"" << name("joystick_ft")
      << "\"/></body></body>\n  </worldbody>\n  <actuator>\n";
  for (std::size_t i = 0; i < 7; ++i) {
    const double limit = scene.joints[i].torque_limit_Nm;
    out << "    <motor name=\"" << name(kNames[i]) << "\" joint=\"" << name(kNames[i]) << "\" ctrlrange=\"" << -limit
        << ' ' << limit << "\"/>\n";
  }
  out << "  </actuator>\n  <sensor>\n    <force name=\"" << name("wrist_force") << "\" site=\"" << name("wrist_ft")
      << "\"/>\n    <torque name=\"" << name("wrist_torque") << "\" site=\"" << name("wrist_ft")
      << "\"/>\n    <force name=\"" << name("joystick_force") << "\" site=\"" << name("joystick_ft")
      << "\"/>\n    <torque name=\"" << name("joystick_torque") << "\" site=\"" << name("joystick_ft")
      << "\"/>\n  </sensor>\n  <keyframe><key name=\"" << name("ready") << "\" qpos=\"";
  for (std::size_t i = 0; i < 7; ++i) out << (i ? " " : "") << scene.joints[i].ready_rad;
  out << "\"/></keyframe>\n</mujoco>\n";
  return out.str();
}

// A file holding text, for what loads a scene from a path; removed with the object.
class SceneFile {
 public:
  explicit SceneFile(const std::string& text) {
    std::string pattern = (std::filesystem::temp_directory_path() / "rtm-scene-XXXXXX.xml").string();
    const int fd = ::mkstemps(pattern.data(), 4);
    if (fd < 0) throw std::runtime_error("SceneFile: cannot make " + pattern);
    ::close(fd);
    path_ = pattern;
    std::ofstream(path_) << text;
  }
  ~SceneFile() { std::filesystem::remove(path_); }
  SceneFile(const SceneFile&) = delete;
  SceneFile& operator=(const SceneFile&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

}  // namespace rtm_test
