// A reference CPU shader for many directional lights: what the culling tables buy and
// what they cost in accuracy, measured with one compiled inner loop.
//
// Per shaded point it returns two RGB terms, the measures of CONVENTIONS.md:
//   diffuse  E(n) = sum_i rgb_i max(0, n . d_i)                       (irradiance)
//   glossy   G(r) = sum_i rgb_i (s+1)/(2 pi) max(0, r . d_i)^s        (normalised Phong)
// and a material combines them as kd / pi * E + ks * G (Lambertian + normalised Phong,
// r the view direction reflected about n). The variants differ only in which lights the
// two sums visit:
//   All        every light of H, for both sums                                  (a)
//   Culled     H lights of the S_H region of n (diffuse) and of r (glossy)      (b)
//   Glossy     diffuse as Culled; glossy by the two-strata rule of glossy_sets.h:
//              L lights of the S_L region of r inside the cone C (first k, rescaled)
//              plus H lights of the S_H region of r outside C                   (c)
//   Clustered  H clustered to at most Q lights (sampling/clustering.h), then culled (d)
// Lights are float structure-of-arrays. A region's lights are read through its index list
// from the one array (default), or from per-region copies (the paper's TexL rows, one
// region per row); the loops are the same source for All and the culled variants, over a
// contiguous or an indexed range. Arithmetic is float (as on a GPU).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "core/accuracy.h"
#include "core/light_list.h"
#include "render/angular_regions.h"
#include "sampling/clustering.h"
#include "render/glossy_sets.h"

namespace lp {

enum class ShadingVariant { All, Culled, Glossy, Clustered };
std::string_view to_string(ShadingVariant variant);
std::vector<ShadingVariant> all_shading_variants();

struct Rgb {
  float r = 0, g = 0, b = 0;
  double luminance() const { return 0.2126 * r + 0.7152 * g + 0.0722 * b; }
};

struct ShadingSample {
  Rgb diffuse;  // E(n)
  Rgb glossy;   // G(r)
};

struct Material {
  Rgb kd{0.5f, 0.5f, 0.5f};    // diffuse albedo
  Rgb ks{0.04f, 0.04f, 0.04f}; // specular weight
  float exponent = 100;         // Phong s
};
Rgb combine(const Material& material, const ShadingSample& sample);

// Lights as float structure-of-arrays (direction, rgb, luminance of rgb).
struct LightBlock {
  std::vector<float> x, y, z, r, g, b, lum;
  size_t size() const { return x.size(); }
  void push(const Light& light);
};

struct ShadingOptions {
  AngularRegionOptions regions;  // S_H (culling regions)
  GlossyOptions glossy;          // L/H ratio, cone, k, S_L regions
  int cluster_max_lights = 0;    // Q for the Clustered variant; 0: |H| / 4 (at least 1)
  ClusterOptions cluster;
  // Copy each region's lights next to each other (the paper's TexL rows) instead of
  // reading the one light array through the region's index list. Copies give contiguous
  // loads but a working set ~(1 + sin alpha) / 2 * regions times the light array, which
  // leaves the cache for large |H| (see docs/shading.md).
  bool region_copies = false;
};

// One frame's tables and light copies. Build times are reported separately from shading.
struct ShadingScene {
  std::shared_ptr<const AngularRegions> regions, cone_regions;  // S_H, S_L (fixed, reusable)
  bool region_copies = false;           // see ShadingOptions
  std::vector<Light> lights;            // H, in progressive order (variants a, b)
  LightBlock all;                       // H as one block
  RegionLights culled;                  // S_H lists over H
  LightBlock culled_block;              // per-region copies, at culled.offsets (region_copies only)
  GlossySets glossy;                    // L, and S_L lists over L
  LightBlock low_block;                 // L as one block
  LightBlock cone_block;                // per-S_L-region copies of L (region_copies only)
  std::vector<Light> clustered;         // at most Q lights
  RegionLights clustered_regions;
  LightBlock clustered_all;             // the clustered lights as one block
  LightBlock clustered_block;           // per-region copies (region_copies only)
  double culled_ms = 0, glossy_ms = 0, cluster_ms = 0;  // table build times
};

// Builds every variant's tables from a progressive L list and |H| = high_count (H is the
// rescaled prefix of L). Throws InputError on bad counts (see glossy_sets.h, clustering.h).
ShadingScene prepare_shading(std::vector<Light> low, int high_count, std::shared_ptr<const AngularRegions> regions,
                             std::shared_ptr<const AngularRegions> cone_regions, const ShadingOptions& options = {});

// Shades one point: n the unit normal, r the unit reflected view direction.
ShadingSample shade(const ShadingScene& scene, ShadingVariant variant, Vec3 normal, Vec3 reflection, float exponent);

// Shades many points (in parallel with TBB when `parallel`).
void shade_points(const ShadingScene& scene, ShadingVariant variant, std::span<const Vec3> normals,
                  std::span<const Vec3> reflections, float exponent, std::span<ShadingSample> out,
                  bool parallel = false);

// Random shading points from a fixed seed: normals uniform on the sphere, view directions
// uniform on each normal's hemisphere, reflections r = 2 (n.v) n - v.
void make_shading_points(int count, uint64_t seed, std::vector<Vec3>& normals, std::vector<Vec3>& reflections);

// The CONVENTIONS.md diffuse and glossy errors of a variant against the map's reference
// (luminance; the same 256 directions serve as normals and as reflection directions).
struct ShadingError {
  double diffuse = 0;
  std::vector<double> glossy;  // one per reference.options.glossy_exponents
};
ShadingError shading_error(const AccuracyReference& reference, const ShadingScene& scene, ShadingVariant variant);

}  // namespace lp
