// Reference CPU shader: one diffuse loop and one Phong loop over float spans, visited by
// every variant. See reference_shader.h.
#include "render/reference_shader.h"

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>

#include "core/error.h"

namespace lp {
namespace {

constexpr int kLanes = 8;  // independent float accumulators: lets the compiler use SIMD

struct Vec3f {
  float x, y, z;
};
Vec3f to_f(Vec3 v) { return {float(v.x), float(v.y), float(v.z)}; }

// Which light of the block the i-th entry of a range is: itself (a contiguous range of
// the all-lights block or of per-region copies), or through a region's index list. The
// loops below are written once over these; the contiguous form vectorises its loads.
struct Contiguous {
  size_t operator()(size_t i) const { return i; }
};
struct Indexed {
  const uint32_t* index;
  size_t operator()(size_t i) const { return index[i]; }
};

// E over lights at(begin) .. at(end - 1) of the block.
template <typename At>
void diffuse_sum(const LightBlock& L, At at, size_t begin, size_t end, Vec3f n, Rgb& out) {
  const float* __restrict x = L.x.data();
  const float* __restrict y = L.y.data();
  const float* __restrict z = L.z.data();
  const float* __restrict r = L.r.data();
  const float* __restrict g = L.g.data();
  const float* __restrict b = L.b.data();
  float ar[kLanes] = {}, ag[kLanes] = {}, ab[kLanes] = {};
  size_t i = begin;
  for (; i + kLanes <= end; i += kLanes)
    for (int l = 0; l < kLanes; ++l) {
      const size_t k = at(i + size_t(l));
      const float c = std::max(0.0f, n.x * x[k] + n.y * y[k] + n.z * z[k]);
      ar[l] += c * r[k], ag[l] += c * g[k], ab[l] += c * b[k];
    }
  for (int l = 0; i < end; ++i, ++l) {
    const size_t k = at(i);
    const float c = std::max(0.0f, n.x * x[k] + n.y * y[k] + n.z * z[k]);
    ar[l] += c * r[k], ag[l] += c * g[k], ab[l] += c * b[k];
  }
  for (int l = 0; l < kLanes; ++l) out.r += ar[l], out.g += ag[l], out.b += ab[l];
}

// max(0, c)^s on kLanes values: exponentiation by squaring for integer s (the same
// multiplications for every lane, so it vectorises), std::pow otherwise.
inline void lobe_power(float* __restrict c, float s, int int_s) {
  if (int_s >= 0) {
    float p[kLanes], base[kLanes];
    for (int l = 0; l < kLanes; ++l) p[l] = 1, base[l] = c[l];
    // No squaring after the top bit: base^(2^k) beyond the exponent would underflow into
    // denormals for cosines that the result itself keeps clear of them.
    for (unsigned e = unsigned(int_s); e;) {
      if (e & 1u)
        for (int l = 0; l < kLanes; ++l) p[l] *= base[l];
      e >>= 1;
      if (e)
        for (int l = 0; l < kLanes; ++l) base[l] *= base[l];
    }
    for (int l = 0; l < kLanes; ++l) c[l] = p[l];
  } else {
    for (int l = 0; l < kLanes; ++l) c[l] = std::pow(c[l], s);
  }
}

inline float int_power(float x, unsigned e) {
  float p = 1;
  for (;;) {
    if (e & 1u) p *= x;
    e >>= 1;
    if (!e) return p;
    x *= x;  // only while bits remain (see lobe_power)
  }
}

int integer_exponent(float s) { return s >= 0 && s <= 4096 && float(int(s)) == s ? int(s) : -1; }

// G over lights [begin, end) whose cosine to r is in (0, upper]: upper >= 1 takes every
// light in the upper hemisphere of r; upper = cos(cone) takes those outside the cone.
template <typename At>
void glossy_sum(const LightBlock& L, At at, size_t begin, size_t end, Vec3f rv, float s, float upper, Rgb& out) {
  const float* __restrict x = L.x.data();
  const float* __restrict y = L.y.data();
  const float* __restrict z = L.z.data();
  const float* __restrict r = L.r.data();
  const float* __restrict g = L.g.data();
  const float* __restrict b = L.b.data();
  const int int_s = integer_exponent(s);
  const float norm = float((double(s) + 1) / (2 * M_PI));
  // Cosines whose power would fall below 1e-30 count as 0 (masked, and raised to the
  // power at floor_cos): their terms are far below float resolution of the sum, and the
  // powers would pass through denormal floats, which cost x86 ~100 cycles each (GPUs flush
  // them to zero). Without this, the culled lists - lights mostly above the horizon, many
  // at small cosines - paid that penalty and the all-lights loop (half its cosines
  // clamped to exactly 0) did not.
  const float floor_cos = s > 0 ? float(std::pow(1e-30, 1.0 / double(s))) : 0.0f;
  float ar[kLanes] = {}, ag[kLanes] = {}, ab[kLanes] = {};
  float c[kLanes], keep[kLanes];
  size_t i = begin;
  for (; i + kLanes <= end; i += kLanes) {
    for (int l = 0; l < kLanes; ++l) {
      const size_t k = at(i + size_t(l));
      const float cc = rv.x * x[k] + rv.y * y[k] + rv.z * z[k];
      // Masks as products, not branches: whether a light is behind, in the cone or too
      // dim is data-dependent, and mispredicted branches cost more than the arithmetic.
      keep[l] = float(cc > floor_cos) * float(cc <= upper);
      c[l] = std::max(cc, floor_cos);
    }
    lobe_power(c, s, int_s);
    for (int l = 0; l < kLanes; ++l) {
      const size_t k = at(i + size_t(l));
      const float w = keep[l] * c[l];
      ar[l] += w * r[k], ag[l] += w * g[k], ab[l] += w * b[k];
    }
  }
  for (int l = 0; i < end; ++i, ++l) {  // the last < kLanes lights
    const size_t k = at(i);
    const float cc = rv.x * x[k] + rv.y * y[k] + rv.z * z[k];
    if (!(cc > 0 && cc <= upper)) continue;
    const float w = cc > floor_cos ? (int_s >= 0 ? int_power(cc, unsigned(int_s)) : std::pow(cc, s)) : 0.0f;
    ar[l] += w * r[k], ag[l] += w * g[k], ab[l] += w * b[k];
  }
  float sr = 0, sg = 0, sb = 0;
  for (int l = 0; l < kLanes; ++l) sr += ar[l], sg += ag[l], sb += ab[l];
  out.r += norm * sr, out.g += norm * sg, out.b += norm * sb;
}

// The L stratum: lights of [begin, end) strictly inside the cone (cos > cos_cone), the
// first k of them, scaled to the luminance of all of them.
template <typename At>
void cone_sum(const LightBlock& L, At at, size_t begin, size_t end, Vec3f rv, float s, float cos_cone, int k, Rgb& out) {
  const float norm = float((double(s) + 1) / (2 * M_PI));
  double lum_in = 0, lum_used = 0;
  float sr = 0, sg = 0, sb = 0;
  int used = 0;
  for (size_t q = begin; q < end; ++q) {
    const size_t i = at(q);
    const float c = rv.x * L.x[i] + rv.y * L.y[i] + rv.z * L.z[i];
    if (!(c > cos_cone)) continue;
    lum_in += L.lum[i];
    if (used < k) {
      const float w = std::pow(c, s);
      sr += w * L.r[i], sg += w * L.g[i], sb += w * L.b[i];
      lum_used += L.lum[i];
      ++used;
    }
  }
  const float scale = lum_used > 0 ? float(lum_in / lum_used) : 1.0f;
  out.r += norm * scale * sr, out.g += norm * scale * sg, out.b += norm * scale * sb;
}

// Copies the lights of each region's list next to each other.
LightBlock region_block(std::span<const Light> lights, const RegionLights& lists) {
  LightBlock block;
  for (auto* v : {&block.x, &block.y, &block.z, &block.r, &block.g, &block.b, &block.lum}) v->reserve(lists.indices.size());
  for (uint32_t i : lists.indices) block.push(lights[i]);
  return block;
}

LightBlock whole_block(std::span<const Light> lights) {
  LightBlock block;
  for (const Light& l : lights) block.push(l);
  return block;
}

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

double rel_rms(const std::vector<double>& ref, const std::vector<double>& est) {
  double se = 0, mean = 0;
  for (size_t k = 0; k < ref.size(); ++k) se += (est[k] - ref[k]) * (est[k] - ref[k]), mean += ref[k];
  mean /= double(ref.size());
  return mean > 0 ? std::sqrt(se / double(ref.size())) / mean : 0.0;
}

}  // namespace

std::string_view to_string(ShadingVariant v) {
  switch (v) {
    case ShadingVariant::All: return "all";
    case ShadingVariant::Culled: return "culled";
    case ShadingVariant::Glossy: return "glossy";
    case ShadingVariant::Clustered: return "clustered";
  }
  return "?";
}

std::vector<ShadingVariant> all_shading_variants() {
  return {ShadingVariant::All, ShadingVariant::Culled, ShadingVariant::Glossy, ShadingVariant::Clustered};
}

Rgb combine(const Material& m, const ShadingSample& s) {
  const float inv_pi = float(1 / M_PI);
  return {m.kd.r * inv_pi * s.diffuse.r + m.ks.r * s.glossy.r, m.kd.g * inv_pi * s.diffuse.g + m.ks.g * s.glossy.g,
          m.kd.b * inv_pi * s.diffuse.b + m.ks.b * s.glossy.b};
}

void LightBlock::push(const Light& l) {
  x.push_back(float(l.direction.x)), y.push_back(float(l.direction.y)), z.push_back(float(l.direction.z));
  r.push_back(float(l.rgb[0])), g.push_back(float(l.rgb[1])), b.push_back(float(l.rgb[2]));
  lum.push_back(float(l.luminance()));
}

ShadingScene prepare_shading(std::vector<Light> low, int high_count, std::shared_ptr<const AngularRegions> regions,
                             std::shared_ptr<const AngularRegions> cone_regions, const ShadingOptions& options) {
  if (!regions || !cone_regions) throw InputError("shading: angular regions are missing");
  ShadingScene s;
  s.regions = std::move(regions);
  s.cone_regions = std::move(cone_regions);

  auto t0 = std::chrono::steady_clock::now();
  s.glossy = make_glossy_sets(std::move(low), high_count, *s.cone_regions, options.glossy);
  s.region_copies = options.region_copies;
  s.low_block = whole_block(s.glossy.low);
  if (s.region_copies) s.cone_block = region_block(s.glossy.low, s.glossy.low_regions);
  s.glossy_ms = ms_since(t0);

  t0 = std::chrono::steady_clock::now();
  s.lights = s.glossy.high;
  s.all = whole_block(s.lights);
  s.culled = assign_lights(*s.regions, s.lights);
  if (s.region_copies) s.culled_block = region_block(s.lights, s.culled);
  s.culled_ms = ms_since(t0);

  t0 = std::chrono::steady_clock::now();
  const int q = options.cluster_max_lights == 0 ? std::max(1, high_count / 4) : options.cluster_max_lights;
  s.clustered = cluster_lights(s.lights, q, options.cluster);
  s.clustered_regions = assign_lights(*s.regions, s.clustered);
  s.clustered_all = whole_block(s.clustered);
  if (s.region_copies) s.clustered_block = region_block(s.clustered, s.clustered_regions);
  s.cluster_ms = ms_since(t0);
  return s;
}

namespace {

// Calls f(block, at, begin, end) for region j's lights: the region's own copies, or the
// whole list through the region's index list.
template <typename F>
void with_region(bool copies, const LightBlock& whole, const LightBlock& copy, const RegionLights& lists, int j, F&& f) {
  const size_t b = lists.offsets[size_t(j)], e = lists.offsets[size_t(j) + 1];
  if (copies)
    f(copy, Contiguous{}, b, e);
  else
    f(whole, Indexed{lists.indices.data()}, b, e);
}

}  // namespace

ShadingSample shade(const ShadingScene& s, ShadingVariant variant, Vec3 normal, Vec3 reflection, float exponent) {
  ShadingSample out;
  const Vec3f n = to_f(normal), r = to_f(reflection);
  constexpr float kNoUpper = 2.0f;  // every cosine is <= 1: no cone excluded
  const bool copies = s.region_copies;
  switch (variant) {
    case ShadingVariant::All:
      diffuse_sum(s.all, Contiguous{}, 0, s.all.size(), n, out.diffuse);
      glossy_sum(s.all, Contiguous{}, 0, s.all.size(), r, exponent, kNoUpper, out.glossy);
      break;
    case ShadingVariant::Culled:
    case ShadingVariant::Glossy: {
      with_region(copies, s.all, s.culled_block, s.culled, s.regions->region_of(normal),
                  [&](const LightBlock& L, auto at, size_t b, size_t e) { diffuse_sum(L, at, b, e, n, out.diffuse); });
      const float upper = variant == ShadingVariant::Culled ? kNoUpper : float(std::cos(s.glossy.cone_half_angle));
      // Glossy: H outside the cone C (every H light for Culled).
      with_region(copies, s.all, s.culled_block, s.culled, s.regions->region_of(reflection),
                  [&](const LightBlock& L, auto at, size_t b, size_t e) {
                    glossy_sum(L, at, b, e, r, exponent, upper, out.glossy);
                  });
      if (variant == ShadingVariant::Glossy)  // L inside C
        with_region(copies, s.low_block, s.cone_block, s.glossy.low_regions, s.cone_regions->region_of(reflection),
                    [&](const LightBlock& L, auto at, size_t b, size_t e) {
                      cone_sum(L, at, b, e, r, exponent, upper, s.glossy.max_cone_lights, out.glossy);
                    });
      break;
    }
    case ShadingVariant::Clustered:
      with_region(copies, s.clustered_all, s.clustered_block, s.clustered_regions, s.regions->region_of(normal),
                  [&](const LightBlock& L, auto at, size_t b, size_t e) { diffuse_sum(L, at, b, e, n, out.diffuse); });
      with_region(copies, s.clustered_all, s.clustered_block, s.clustered_regions, s.regions->region_of(reflection),
                  [&](const LightBlock& L, auto at, size_t b, size_t e) {
                    glossy_sum(L, at, b, e, r, exponent, kNoUpper, out.glossy);
                  });
      break;
  }
  return out;
}

void shade_points(const ShadingScene& scene, ShadingVariant variant, std::span<const Vec3> normals,
                  std::span<const Vec3> reflections, float exponent, std::span<ShadingSample> out, bool parallel) {
  if (normals.size() != reflections.size() || out.size() != normals.size())
    throw InputError("shading: normals, reflections and outputs differ in count");
  auto body = [&](size_t i) { out[i] = shade(scene, variant, normals[i], reflections[i], exponent); };
  if (parallel)
    tbb::parallel_for(size_t(0), normals.size(), body);
  else
    for (size_t i = 0; i < normals.size(); ++i) body(i);
}

void make_shading_points(int count, uint64_t seed, std::vector<Vec3>& normals, std::vector<Vec3>& reflections) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss;
  auto unit = [&] {
    for (;;) {
      const Vec3 v{gauss(rng), gauss(rng), gauss(rng)};
      const double len = length(v);
      if (len > 1e-9) return (1 / len) * v;
    }
  };
  normals.resize(size_t(count));
  reflections.resize(size_t(count));
  for (int i = 0; i < count; ++i) {
    const Vec3 n = unit();
    Vec3 v = unit();
    if (dot(n, v) < 0) v = -v;
    normals[size_t(i)] = n;
    reflections[size_t(i)] = normalize(2 * dot(n, v) * n - v);
  }
}

ShadingError shading_error(const AccuracyReference& ref, const ShadingScene& scene, ShadingVariant variant) {
  const auto& dirs = ref.directions;
  ShadingError err;
  std::vector<double> est(dirs.size());
  for (size_t k = 0; k < dirs.size(); ++k) est[k] = shade(scene, variant, dirs[k], dirs[k], 1).diffuse.luminance();
  err.diffuse = rel_rms(ref.diffuse, est);
  for (size_t g = 0; g < ref.options.glossy_exponents.size(); ++g) {
    const float s = float(ref.options.glossy_exponents[g]);
    for (size_t k = 0; k < dirs.size(); ++k) est[k] = shade(scene, variant, dirs[k], dirs[k], s).glossy.luminance();
    err.glossy.push_back(rel_rms(ref.glossy[g], est));
  }
  return err;
}

}  // namespace lp
