// Glossy light sets: H as a rescaled prefix of L, and the S_L cone lists.
#include "render/glossy_sets.h"

#include <fmt/format.h>

#include <cmath>

#include "core/error.h"

namespace lp {

std::vector<Light> high_subset(std::span<const Light> low, int high_count) {
  if (high_count < 1 || size_t(high_count) > low.size())
    throw InputError(fmt::format("glossy sets: |H| must be between 1 and |L| = {}, got {}", low.size(), high_count));
  std::vector<Light> high(low.begin(), low.begin() + high_count);
  std::array<double, 3> all{0, 0, 0}, prefix{0, 0, 0};
  for (const Light& l : low)
    for (int c = 0; c < 3; ++c) all[size_t(c)] += l.rgb[size_t(c)];
  for (const Light& l : high)
    for (int c = 0; c < 3; ++c) prefix[size_t(c)] += l.rgb[size_t(c)];
  // Per channel, so that total power is exact (a progressive prefix carries ~|H|/|L| of it).
  std::array<double, 3> k{1, 1, 1};
  for (int c = 0; c < 3; ++c)
    if (prefix[size_t(c)] != 0) k[size_t(c)] = all[size_t(c)] / prefix[size_t(c)];
  const double sa = double(low.size()) / high_count;
  for (Light& l : high) {
    for (int c = 0; c < 3; ++c) l.rgb[size_t(c)] *= k[size_t(c)];
    l.solid_angle *= sa;
  }
  return high;
}

GlossySets make_glossy_sets(std::vector<Light> low, int high_count, const AngularRegions& cone_regions,
                            const GlossyOptions& options) {
  if (low.empty()) throw InputError("glossy sets: the low-intensity set L is empty");
  if (!(options.cone_half_angle_deg > 0 && options.cone_half_angle_deg <= 90))
    throw InputError(
        fmt::format("glossy sets: the cone half-angle must be in (0, 90] degrees, got {}", options.cone_half_angle_deg));
  if (options.max_cone_lights < 1)
    throw InputError(fmt::format("glossy sets: max_cone_lights (k) must be at least 1, got {}", options.max_cone_lights));
  GlossySets sets;
  sets.high = high_subset(low, high_count);
  sets.cone_half_angle = options.cone_half_angle_deg * M_PI / 180;
  sets.max_cone_lights = options.max_cone_lights;
  sets.low_regions = assign_lights(cone_regions, low, sets.cone_half_angle);
  sets.low = std::move(low);
  return sets;
}

}  // namespace lp
