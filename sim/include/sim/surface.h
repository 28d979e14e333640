// SPDX-License-Identifier: Apache-2.0
// What the tool presses on: the table top as a spring-damper between the tool tip and the
// ground, lumping the surface's own compliance with the tool's and the wrist sensor's in series
// (docs/pa10-model.md lists the figures and where each comes from).
//
// In the scene the table top is a plate on a vertical slide joint ("surface"): the joint's
// spring is the surface's stiffness, its damping gives the stated damping ratio with the plate's
// mass, and the spring is preloaded with the plate's weight so the top rests at its nominal
// height. MuJoCo's own contact between the tool and the plate is made far stiffer (solref and
// solimp in the scene), so the stiffness the tool meets is the configured one
// (tests/sim/identification_test.cpp measures it).
//
// Friction along the top is the plant's own (Pa10Plant::apply_tool_friction), not MuJoCo's:
// MuJoCo's friction cone on this near-rigid contact made the tool chatter as it slid (one wrist
// sample in ten read almost no force, the next nearly twice it; docs/pa10-model.md, "Friction").
#pragma once

#include <span>
#include <stdexcept>
#include <string>
#include <string_view>

namespace rtm::sim {

// The tool tip's Coulomb friction on every surface unless told otherwise (pa10-sim
// --friction): a steel tip on a dry table lies between 0.2 and 0.6.
inline constexpr double kDefaultFriction = 0.3;

struct Surface {
  std::string name;         // a preset's name, or "custom"
  double stiffness_N_m = 0; // normal stiffness the tool tip meets
  double damping_ratio = 0; // of the plate on its spring
  double friction = kDefaultFriction;  // Coulomb coefficient between the tool tip and the top
};

// sponge, rubber, wood, steel: softest to stiffest.
std::span<const Surface> surface_presets();

// The default surface of pa10-sim and of the plant.
const Surface& default_surface();

// A preset's name or a stiffness in N/m ("30000", "3e4"; damping ratio then that of the
// nearest preset below it). Throws std::invalid_argument naming the text and what is accepted.
Surface parse_surface(std::string_view text);

}  // namespace rtm::sim
