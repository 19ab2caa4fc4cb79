// Monte Carlo estimators of the radiance reflected at a shading point lit by an
// environment map (Kronander et al. 2015, seed 002, eq. 1):
//   L_r = integral of L(w) f(wo, w) V(w) max(0, n.w) dw
// over the map as a piecewise-constant function of direction (its pixels), per channel.
//
//   reference  the exact pixel sum: every pixel's radiance times the lobe integrated over
//              the pixel (supersampled k x k in equal solid angles where the lobe is narrow)
//   MIS        N_rho lobe samples + N_L map samples, balance heuristic (Veach 1995):
//              sum_i L f V cos / (N_rho q_rho(w_i) + N_L q_L(w_i)); unbiased
//   BIS        sampling-importance-resampling (Burke et al. 2005, Talbot et al. 2005): M
//              proposals from q (the lobe, optionally mixed with the map), weights
//              gamma / q with gamma = L_Y (f cos)_Y the unoccluded luminance product, Z = mean
//              weight, N of them resampled ∝ weight; estimate Z / N sum (L f cos V)/gamma.
//              Unbiased for any M >= 1 (the resampled points only carry the colour and V).
// Visibility is the expensive factor of a renderer, so the sample budget counts shading
// evaluations with V: N_rho + N_L for MIS, N for BIS (M proposals are lookups only).
#pragma once

#include <functional>

#include "core/envmap.h"
#include "core/vec3.h"
#include "render/brdf.h"
#include "render/env_distribution.h"
#include "render/rng.h"

namespace lp {

struct ShadingPoint {
  Vec3 normal{0, 0, 1};  // unit
  Vec3 view{0, 0, 1};    // unit, towards the viewer; above the surface
  Brdf brdf;
  // Binary visibility of direction w from the point; empty: unoccluded.
  std::function<bool(Vec3)> visible;
};
// Throws InputError on a non-unit normal or view, a view below the surface, or a bad lobe.
void validate(const ShadingPoint& point);

// The integrand's luminance product without visibility, gamma(w) = L_Y(w) (f cos)_Y(w):
// the target of BIS and SMC.
double product_target(const EnvDistribution& map, const ShadingPoint& point, Vec3 w);

struct ReferenceOptions {
  // Supersampling per pixel edge inside the lobe; 0: automatic (1 for lambertian, enough
  // for the blinn-phong lobe to vary < ~0.1 % across a sub-pixel).
  int subdivision = 0;
};
Rgb reference_reflected(const EnvMap& map, const ShadingPoint& point, const ReferenceOptions& options = {});

struct MisOptions {
  int lobe_samples = 8;  // N_rho
  int map_samples = 8;   // N_L
};
// Throws InputError when both counts are zero or one is negative.
Rgb estimate_mis(const EnvDistribution& map, const ShadingPoint& point, const MisOptions& options, Rng& rng);

struct BisOptions {
  int samples = 8;                // N, resampled (each costs a visibility test)
  int proposals_per_sample = 8;   // M = proposals_per_sample x N
  double proposal_map_share = 0;  // proposals from the map with this probability (0: lobe only, as the paper)
};
Rgb estimate_bis(const EnvDistribution& map, const ShadingPoint& point, const BisOptions& options, Rng& rng);

// SIR building block shared with SMC: M proposals -> N equally weighted points ~ gamma / Z
// (approximately), and the unbiased estimate Z_hat of Z = integral of gamma.
struct Resampled {
  std::vector<Vec3> directions;
  std::vector<double> target;  // gamma at each direction
  double z = 0;
};
Resampled sample_importance_resample(const EnvDistribution& map, const ShadingPoint& point, int proposals,
                                     int samples, double proposal_map_share, Rng& rng);
// Per-channel (L f cos V) / gamma at w: what each SIR/SMC point contributes per unit of Z.
Rgb colour_ratio(const EnvDistribution& map, const ShadingPoint& point, Vec3 w);

}  // namespace lp
