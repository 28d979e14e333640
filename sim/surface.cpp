// SPDX-License-Identifier: Apache-2.0
#include "sim/surface.h"

#include <array>
#include <cerrno>
#include <cmath>
#include <cstdlib>

namespace rtm::sim {

namespace {

// docs/pa10-model.md, "Surfaces", gives the reasoning and sources for each figure.
const std::array<Surface, 4> kPresets{{
    {"sponge", 300, 1.0, kDefaultFriction},
    {"rubber", 5'000, 0.5, kDefaultFriction},
    {"wood", 30'000, 0.3, kDefaultFriction},
    {"steel", 100'000, 0.2, kDefaultFriction},
}};

constexpr double kMinStiffness_N_m = 10;
constexpr double kMaxStiffness_N_m = 1e6;  // the plate's resonance stays below 1/(1 ms step)

}  // namespace

std::span<const Surface> surface_presets() { return kPresets; }

const Surface& default_surface() { return kPresets.back(); }

Surface parse_surface(std::string_view text) {
  for (const Surface& preset : kPresets)
    if (text == preset.name) return preset;
  const std::string copy(text);
  char* end = nullptr;
  errno = 0;
  const double stiffness = std::strtod(copy.c_str(), &end);
  const bool number = !copy.empty() && end == copy.c_str() + copy.size() && errno == 0;
  if (!number || !std::isfinite(stiffness) || stiffness < kMinStiffness_N_m ||
      stiffness > kMaxStiffness_N_m)
    throw std::invalid_argument("surface '" + copy +
                                "': expected sponge, rubber, wood, steel or a stiffness in N/m "
                                "from 10 to 1e6");
  Surface surface{"custom", stiffness, kPresets.front().damping_ratio};
  for (const Surface& preset : kPresets)
    if (preset.stiffness_N_m <= stiffness) surface.damping_ratio = preset.damping_ratio;
  return surface;
}

}  // namespace rtm::sim
