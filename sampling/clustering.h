// Light clustering (Havran et al. 2005, section 4.3): merges lights of similar
// direction so that at most Q remain, keeping the order and the ids stable.
#pragma once

#include <vector>

#include "core/light_list.h"

namespace lp {

struct ClusterOptions {
  // c_f: corrects for covering the (hemi)sphere with discs; the paper gives 1.8 - 1.9.
  double correction = 1.85;
  // The lights cover only the upper hemisphere (as in the paper): Q clusters share 2 pi sr
  // instead of 4 pi sr. Only the radius changes; no light is dropped.
  bool upper_hemisphere_only = false;
};

// The cluster radius for at most Q clusters. If Q clusters covered the domain uniformly,
// each would cover Omega / Q, and a cap of angular radius eps covers about pi sin^2(eps)
// (its projected disc). With Omega = 2 pi (hemisphere) that is the paper's
// eps = c_f asin(sqrt(2 / Q)); on the full sphere Omega = 4 pi gives
// eps = c_f asin(sqrt(4 / Q)). The argument of asin is clamped at 1 (Q < 2 resp. 4).
double cluster_radius(int max_lights, const ClusterOptions& options = {});

// Processes the lights in input order: each light not yet in a cluster starts one and
// takes every unassigned light within eps of it (angle to the seed, not to the running
// mean). A cluster's direction is the normalised plain mean of its members' directions
// (the paper averages directions; not power-weighted; if the mean is zero, the seed's
// direction), rgb and solid_angle are sums, id is the seed's id. Clusters come out in the
// order of their seeds. If there are more than max_lights clusters, eps grows by 10 % and
// clustering restarts, so the result never has more than max_lights lights (eps >= pi
// puts everything in one cluster). Per-channel power is preserved up to rounding.
// Candidates are found in a band of zenith angle |theta - theta_seed| <= eps over lights
// sorted by theta, skipping assigned ones; worst case O(n^2), typically far less.
// Throws InputError when max_lights < 1.
std::vector<Light> cluster_lights(const std::vector<Light>& lights, int max_lights,
                                  const ClusterOptions& options = {});

}  // namespace lp
