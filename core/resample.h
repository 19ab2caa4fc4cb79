// Conversion between layouts and rotation into the world frame, with filtering that
// preserves power: each destination pixel is supersampled, every sample is attributed
// to the source pixel it falls in, and each source pixel's power is spread over its
// samples in proportion to their solid angles (or, if no sample hit it, given whole to
// the destination pixel holding its centre). Total power over the valid region is
// therefore kept to float rounding, and a one-pixel sun keeps its direction when going
// down in resolution instead of being aliased away. Before that final normalisation the
// per-destination sample weights are balanced (a few rounds of iterative proportional
// fitting) so that a constant map stays nearly constant; it stays exactly constant where
// the grids nest (healpix to healpix).
//
// Exact path: when source and destination are both row grids (latlong or hemisphere)
// and world_from_source is, to within 1e-9 per matrix element, the identity, a yaw
// Rz(a) by any angle, the half-turn about X Rx(180) = diag(1, -1, -1) (theta -> pi - theta,
// phi -> -phi), or a composition Rz(a) Rx(180), pixels stay rectangles in
// (phi, cos theta) and resample() box-filters with exact overlap areas instead of
// supersampling: destination value = sum over valid source pixels of
// L_s * overlap(s, d) / Omega_d. Power is then exact (to double rounding) and a constant
// map stays exactly constant; samples_per_edge is not used, min_valid_fraction applies
// to the valid source area, and destination pixels with no valid source area (outside
// the source's domain) are invalid. Everything else (healpix, general rotations) takes
// the supersampled path.
#pragma once

#include "core/envmap.h"
#include "core/vec3.h"

namespace lp {

struct ResampleOptions {
  // Samples per destination pixel edge (supersampled path only). 0 chooses it from the
  // ratio of mean pixel solid angles so that samples are about a quarter of a source
  // pixel (capped at 16; a power of two for healpix, which subdivides into NESTED
  // children). Raise it only to check convergence.
  int samples_per_edge = 0;
  // Rotation world_from_source applied to the source map (identity: same frame).
  Mat3 world_from_source{};
  // A destination pixel is valid when at least this fraction of its samples hit valid
  // source pixels (and lie inside the source layout's domain); on the exact path, when
  // at least this fraction of its solid angle is covered by valid source pixels.
  double min_valid_fraction = 0.5;
};

// Resample `src` into `layout`. For latlong/hemisphere, width x height; for healpix,
// `width` is nside. Throws InputError on sizes the layout does not allow.
EnvMap resample(const EnvMap& src, Layout layout, int width, int height,
                const ResampleOptions& options = {});

// The same map turned into the world frame by world_from_map, in the same layout and size.
EnvMap rotate(const EnvMap& src, const Mat3& world_from_map);

}  // namespace lp
