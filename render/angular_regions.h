// Angular regions (Havran et al. 2005, section 4.1): which directional lights can light a
// surface whose normal lies in a given patch of the sphere, decided once per frame so that
// a shader loops over those lights only.
//
// Centres: a spherical Fibonacci lattice (core/accuracy.h fibonacci_sphere). It takes any
// count (the paper used ~200; HEALPix only offers 12 * 4^k), its cells are near-equal in
// area and shape, and it is a closed formula a renderer can reproduce.
//
// Region of a direction: a cube-map look-up table, OpenGL convention (faces +X, -X, +Y, -Y,
// +Z, -Z; the major axis picks the face, ties go to X, then Y; (sc, tc) per the OpenGL
// cube-map table; texel (s, t) = floor(face_size * (sc / |ma| + 1) / 2), likewise t; LUT
// index = (face * face_size + t) * face_size + s). Each texel holds the centre nearest to
// the texel's centre, so a region is a union of texels, not an exact Voronoi cell.
//
// Radius alpha_j: the largest angle from centre j to any direction whose look-up gives j,
// MEASURED over the corners of its texels (texel edges are great-circle arcs and the
// angle from a point is convex on a hemisphere, so the farthest point is a corner).
//
// Which lights a region keeps: light i can light some normal n of region j iff
// angle(n, d_i) < pi/2 for some n within alpha_j of P_j, i.e. iff angle(P_j, d_i) <
// alpha_j + pi/2. So beta_j = alpha_j + pi/2 with alpha_j the region's RADIUS. The paper
// writes beta = alpha/2 + pi/2 with alpha/2 the spacing of neighbouring centres, which is
// larger than a cell's radius, so it is the same rule with a looser margin; the
// exhaustive test (tests/sampling/angular_regions_test.cpp) shows that half our radius is
// not enough. Lists are in ascending light index: the progressive order of the sampler
// survives inside each region (Observation 1).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "core/light_list.h"
#include "core/vec3.h"

namespace lp {

struct AngularRegionOptions {
  int regions = 256;       // region centres (the paper used ~200)
  int lut_face_size = 64;  // cube-map LUT texels per face edge (~1.4 deg texels)
};

// Cube-map addressing shared by the LUT, its export and any renderer (see above).
int cube_texel_of(Vec3 direction, int face_size);
// Direction through a point of texel `index`, at (s + fs, t + ft) with fs, ft in [0, 1]
// (0.5, 0.5 is the texel centre); unit length.
Vec3 cube_texel_direction(int index, int face_size, double fs = 0.5, double ft = 0.5);

class AngularRegions {
 public:
  // Throws InputError when regions < 1 or lut_face_size < 1.
  explicit AngularRegions(const AngularRegionOptions& options = {});

  int count() const { return int(centres_.size()); }
  int face_size() const { return face_size_; }
  const std::vector<Vec3>& centres() const { return centres_; }
  // alpha_j in radians, measured (see above).
  const std::vector<double>& radius() const { return radius_; }
  double max_radius() const;
  // LUT: 6 * face_size^2 region ids.
  const std::vector<int32_t>& lut() const { return lut_; }
  int region_of(Vec3 direction) const { return lut_[size_t(cube_texel_of(direction, face_size_))]; }

 private:
  int face_size_;
  std::vector<Vec3> centres_;
  std::vector<double> radius_;
  std::vector<int32_t> lut_;
};

// Per-region light index lists, compressed-row: region j holds
// indices[offsets[j] .. offsets[j + 1]), ascending.
struct RegionLights {
  std::vector<uint32_t> offsets;  // count() + 1
  std::vector<uint32_t> indices;
  double reach = 0;               // radians beyond each region's radius (pi/2 for culling)
  size_t size(int region) const { return offsets[size_t(region) + 1] - offsets[size_t(region)]; }
};

// Region j keeps light i iff angle(P_j, d_i) <= alpha_j + reach (plus 1e-6 rad of slack
// for rounding). reach = pi/2 culls lights that are below the horizon of every normal in
// the region; a smaller reach (the glossy cone) keeps a narrower set. Throws InputError
// on a negative reach.
RegionLights assign_lights(const AngularRegions& regions, std::span<const Light> lights, double reach = M_PI / 2);

}  // namespace lp
