// GGX prefiltered specular cube maps and the DFG lookup table (split-sum approximation,
// Karis 2013, "Real Shading in Unreal Engine 4"; as Filament's cmgen and three.js PMREM use).
//
// The chain: one cube per roughness, level k with faces N >> k, perceptual roughness
// r_k = k / (K - 1) over the K = log2(N / M) + 1 cube levels down to the smallest face M
// (GGX alpha = r^2). Faces below 16 texels cannot hold a rough lobe's variation (at r = 1
// and 1 x 1 faces the error is ~50 %), so the chain stops at M = 16 by default, and
// OpenEXR's smaller mip levels hold box-filtered copies of the last one. Each texel in
// direction R holds, with N = V = R,
//   P(R) = Integral L(l) D(h) max(R.l, 0) dl / Integral D(h) max(R.l, 0) dl,  h = (l + R) / |l + R|,
// the quantity Karis' importance-sampled estimator converges to; level 0 (r = 0) is the map.
// A renderer reads P at the lod of its roughness, multiplies by F0 * A + B from the DFG table
// at (n.v, r), and has the specular image-based lighting.
//
// Frame: OpenEXR's cube map is y-up, our world z-up; core/openexr_cube.h has the mapping
// (openexr_from_world) and OpenEXR's own exrenvmap turns the cube's level 0 back into the
// latlong map it came from (tested).
//
// Each level is summed directly over the source cube's mip of the same face size (no Monte
// Carlo): importance sampling of D, even filtered (Krivanek & Colbert 2008), left 10-16 %
// RMS errors around the bright windows of a church probe, where the direct sum is within
// 1-6 % of brute-force integration of the whole map (tests/render/prefilter_test.cpp).
#pragma once

#include <array>
#include <functional>
#include <string>
#include <vector>

#include "core/envmap.h"
#include "core/openexr_cube.h"  // openexr_from_world: the frame above
#include "core/vec3.h"

namespace lp {

struct PrefilterOptions {
  int face_size = 128;     // level 0 face edge, a power of two in [4, 2048]
  int min_face_size = 16;  // the chain's last (r = 1) level, a power of two <= face_size
};

struct CubeLevel {
  int face_size = 0;
  double roughness = 0;     // perceptual roughness r (alpha = r^2)
  std::vector<float> rgb;   // face_size x 6 face_size, faces +X -X +Y -Y +Z -Z stacked (OpenEXR)
};

struct PrefilteredCube {
  std::vector<CubeLevel> levels;  // roughness 0 .. 1
  Units units = Units::Relative;
};

// InputError when the map has invalid pixels or covers a hemisphere only (the chain needs
// the whole sphere: fill it first), or when the options are out of range.
// `label` (the map's file) starts the messages about the map when given.
PrefilteredCube prefilter_ggx(const EnvMap& map, const PrefilterOptions& options = {}, const std::string& label = "");

// P(R) at perceptual roughness r > 0 by summing over every pixel of the map with exact
// solid angles: the reference the chain is measured against.
std::array<double, 3> prefiltered_radiance_brute_force(const EnvMap& map, Vec3 world_direction, double roughness);
// The chain read back at a world direction and level (bilinear within the face).
std::array<double, 3> prefiltered_lookup(const PrefilteredCube& cube, int level, Vec3 world_direction);

// The split-sum DFG table: size x size entries, u = n.v (texel centres over (0, 1]), v =
// perceptual roughness r (texel centres over [0, 1]), each (A, B) with
// A = Integral f_spec(F = 1) (1 - (1 - v.h)^5) n.l dl,  B = Integral f_spec(F = 1) (1 - v.h)^5 n.l dl,
// GGX D with height-correlated Smith visibility (Heitz 2014), so that a renderer's specular
// is prefiltered * (F0 * A + B). `samples` GGX samples per entry.
struct DfgTable {
  int size = 0;
  std::vector<float> ab;  // row-major, row = roughness, 2 floats per entry
};
DfgTable compute_dfg_table(int size = 128, int samples = 16384);  // 1,024 err by 0.01 at grazing n.v
// (A, B) at (n.v, r) by a fine midpoint quadrature over the hemisphere of l (no importance
// sampling): the independent reference the table is tested against. r >= 0.2.
std::array<double, 2> dfg_by_quadrature(double n_dot_v, double roughness);

// Writes the chain as one OpenEXR file: tiled, MIPMAP_LEVELS (ROUND_DOWN), envmap = cube,
// level k = the chain's level k; OpenEXR's levels past the chain hold box-filtered copies of
// its last level (width 1, height below 6: its mean) and are no part of the chain. Records lightprobe.roughness (one
// float per cube level) and lightprobe.units.
void write_prefiltered_cube(const std::string& path, const PrefilteredCube& cube);
// InputError unless `path` ends in .exr (no other format holds the chain): check before working.
void check_prefiltered_cube_path(const std::string& path);
// The table as an RGB float EXR (R = A, G = B, B = 0), row 0 = roughness 0.
void write_dfg_table(const std::string& path, const DfgTable& table);

}  // namespace lp
