// Glossy light sets (Havran et al. 2005, section 4.2): a dense low-intensity set L and a
// sparse high-intensity set H drawn from the same progressive points, so that H is a
// prefix of L (the same directions and ids) carrying more power per light.
//
// Two-strata rule for a glossy lobe around the reflected direction r: the cone C of
// half-angle gamma/2 around r is estimated from the L lights inside C, and the rest of the
// sphere from the H lights outside C. The two strata are disjoint, so no energy is
// counted twice. If more than k L lights fall inside C, only the first k (in progressive
// order) are used and their sum is scaled by (luminance of all L lights in C) /
// (luminance of the first k) - the cone's energy is kept, its sampling gets coarser.
//
// The L lights that can fall in C are found through a second, finer set of angular
// regions S_L looked up by r: region j of S_L keeps the L lights within alpha_j + gamma/2
// of its centre, which holds every light within gamma/2 of any r in the region.
// The diffuse term and the H part of the glossy term use the ordinary culling regions
// S_H (angular_regions.h, reach pi/2) over H.
#pragma once

#include <span>
#include <vector>

#include "core/light_list.h"
#include "render/angular_regions.h"

namespace lp {

struct GlossyOptions {
  int low_per_high = 8;             // |L| / |H|
  double cone_half_angle_deg = 8;   // gamma / 2: the cone C around the reflected direction
  int max_cone_lights = 256;        // k: L lights used per cone at most (the paper: 216)
  AngularRegionOptions cone_regions{512, 64};  // S_L: finer than the culling regions
};

struct GlossySets {
  std::vector<Light> low;           // L, in progressive order
  std::vector<Light> high;          // H = the first |H| lights of L, power rescaled
  RegionLights low_regions;         // S_L lists over L (reach = cone half-angle)
  double cone_half_angle = 0;       // radians
  int max_cone_lights = 0;
};

// H from L: the first `high_count` lights of L, each channel scaled so that H carries the
// same total power as L. Throws InputError when high_count is not in [1, |L|].
std::vector<Light> high_subset(std::span<const Light> low, int high_count);

// Builds H and the S_L lists. `low` must be a progressive list (pharr, hemigon without
// Lloyd relaxation). Throws InputError on an empty L, |H| out of range, a cone half-angle
// outside (0, 90] degrees, or max_cone_lights < 1.
GlossySets make_glossy_sets(std::vector<Light> low, int high_count, const AngularRegions& cone_regions,
                            const GlossyOptions& options = {});

}  // namespace lp
