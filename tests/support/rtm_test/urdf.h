// SPDX-License-Identifier: Apache-2.0
// Small URDF models written inline, as MuJoCo's tests write theirs: a serial chain whose every
// pose a test can work out by hand, instead of the full PA10 model.
//
//   const auto urdf = rtm_test::serial_chain_urdf(std::vector<rtm_test::UrdfJoint>(7, {.xyz = {0, 0, 0.1}}),
//                                                 {0, 0, 0.05}, {std::numbers::pi, 0, 0});
//   auto kinematics = rtm::pa10::Kinematics::from_urdf_string(urdf, "inline.urdf");
//   // seven joints about z, 0.1 m apart; tool0 0.75 m up, pointing down
#pragma once

#include <array>
#include <sstream>
#include <string>
#include <vector>

namespace rtm_test {

// A revolute joint of an inline chain: where it sits on the link before it (m, and roll pitch
// yaw in rad), the axis it turns about (in its own frame) and its limits.
struct UrdfJoint {
  std::array<double, 3> xyz{};
  std::array<double, 3> rpy{};
  std::array<double, 3> axis{0, 0, 1};
  double lower_rad = -3;
  double upper_rad = 3;
  double velocity_rad_s = 1;
};

// base_link -j1-> l1 -j2-> ... -jN-> lN, then a fixed joint (tool_xyz, tool_rpy) to tool0.
inline std::string serial_chain_urdf(const std::vector<UrdfJoint>& joints, std::array<double, 3> tool_xyz = {},
                                     std::array<double, 3> tool_rpy = {}) {
  std::ostringstream out;
  out.precision(17);
  const auto triple = [&](const std::array<double, 3>& v) { out << v[0] << ' ' << v[1] << ' ' << v[2]; };
  const auto origin = [&](const std::array<double, 3>& xyz, const std::array<double, 3>& rpy) {
    out << "<origin xyz=\"";
    triple(xyz);
    out << "\" rpy=\"";
    triple(rpy);
    out << "\"/>";
  };
  out << "<robot name=\"inline\">\n  <link name=\"base_link\"/>\n";
  std::string parent = "base_link";
  for (std::size_t i = 0; i < joints.size(); ++i) {
    const UrdfJoint& j = joints[i];
    std::string child = "l";
    child += std::to_string(i + 1);  // (not "l" + ...: GCC 12 warns falsely, -Wrestrict)
    out << "  <link name=\"" << child << "\"/>\n  <joint name=\"j" << i + 1 << "\" type=\"revolute\"><parent link=\""
        << parent << "\"/><child link=\"" << child << "\"/>";
    origin(j.xyz, j.rpy);
    out << "<axis xyz=\"";
    triple(j.axis);
    out << "\"/><limit lower=\"" << j.lower_rad << "\" upper=\"" << j.upper_rad << "\" velocity=\"" << j.velocity_rad_s
        << "\" effort=\"1\"/></joint>\n";
    parent = child;
  }
  out << "  <link name=\"tool0\"/>\n  <joint name=\"tool\" type=\"fixed\"><parent link=\"" << parent
      << "\"/><child link=\"tool0\"/>";
  origin(tool_xyz, tool_rpy);
  out << "</joint>\n</robot>\n";
  return out.str();
}

}  // namespace rtm_test
