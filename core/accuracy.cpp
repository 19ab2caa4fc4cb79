#include "core/accuracy.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/pixel_rings.h"
#include "core/ring_integrals.h"

namespace lp {

namespace {

// Buffers a thread keeps between calls, up to maps of 2^21 pixels (~70 MB); larger maps
// get fresh ones.
struct Scratch {
  RingSums sums;
  std::vector<RingArc> lit;
  std::vector<double> per_ring, by_ring;
};
constexpr size_t kKeptPixels = size_t(1) << 21;

double rel_rms(const std::vector<double>& ref, const std::vector<double>& est) {
  double sq = 0, mean = 0;
  for (size_t k = 0; k < ref.size(); ++k) {
    const double d = est[k] - ref[k];
    sq += d * d;
    mean += ref[k];
  }
  if (ref.empty()) return 0;
  sq /= double(ref.size());
  mean /= double(ref.size());
  if (mean <= 0) return sq == 0 ? 0.0 : INFINITY;  // black reference: any light is wrong
  return std::sqrt(sq) / mean;
}

uint64_t splitmix64(uint64_t& state) {
  uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

double unit_double(uint64_t& state) { return double(splitmix64(state) >> 11) * 0x1.0p-53; }

}  // namespace

std::vector<Vec3> fibonacci_sphere(int count) {
  std::vector<Vec3> out;
  if (count <= 0) return out;
  out.reserve(size_t(count));
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int k = 0; k < count; ++k) {
    const double z = 1.0 - (2.0 * k + 1.0) / count;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = k * golden;
    out.push_back({r * std::cos(phi), r * std::sin(phi), z});
  }
  return out;
}

std::vector<Vec3> occluder_caps(int count, uint64_t seed) {
  std::vector<Vec3> out;
  uint64_t state = seed;
  for (int i = 0; i < count; ++i) {
    const double z = 1.0 - 2.0 * unit_double(state);
    const double phi = 2.0 * M_PI * unit_double(state);
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    out.push_back({r * std::cos(phi), r * std::sin(phi), z});
  }
  return out;
}

double phong_lobe(double cos_angle, double exponent) {
  if (!(cos_angle > 0)) return 0;
  return (exponent + 1) / (2 * M_PI) * std::pow(cos_angle, exponent);
}

// On the map's rings (core/ring_integrals.h): ring by ring the diffuse sum and the narrow
// lobes of every direction, then the wide lobes through harmonics, then cap by cap.
AccuracyReference make_accuracy_reference(const EnvMap& map, const AccuracyOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  AccuracyReference ref;
  ref.options = options;
  ref.directions = fibonacci_sphere(options.directions);
  const size_t nd = ref.directions.size();
  const size_t ne = options.glossy_exponents.size();
  ref.diffuse.assign(nd, 0.0);
  ref.glossy.assign(ne, std::vector<double>(nd, 0.0));
  if (nd == 0) return ref;

  // A thread waiting in the parallel loops below may run another task that builds a
  // reference (TBB's work stealing): only the outermost call on a thread uses its buffers.
  thread_local Scratch kept;
  thread_local bool kept_in_use = false;
  Scratch fresh;
  const bool keep = map.pixel_count() <= kKeptPixels && !kept_in_use;
  Scratch& scratch = keep ? kept : fresh;
  struct Release {
    bool active;
    ~Release() {
      if (active) kept_in_use = false;
    }
  } release{keep};
  if (keep) kept_in_use = true;
  fill_ring_sums(map, scratch.sums);
  const RingSums& sums = scratch.sums;
  const RingLayout& L = *sums.layout;
  const size_t nr = L.rings.size();
  std::vector<double> t_min(ne);
  for (size_t e = 0; e < ne; ++e) {
    const double s = options.glossy_exponents[e];
    t_min[e] = s > 0 ? std::pow(kLobeTail, 1.0 / s) : 0.0;
  }
  const std::vector<RingAxis> axes(ref.directions.begin(), ref.directions.end());
  std::vector<size_t> narrow;  // the exponents summed pixel by pixel
  for (size_t e = 0; e < ne; ++e)
    if (!is_harmonic(options.glossy_exponents[e])) narrow.push_back(e);
  // Ring by ring (a ring's prefix sums stay in cache for every direction): the arcs where
  // each direction's cosine is positive, its diffuse sum and its narrow lobes, per (ring,
  // direction); then added in ring order, so that the result does not depend on threads.
  std::vector<RingArc>& lit = scratch.lit;
  lit.resize(nr * nd);
  std::vector<double>& per_ring = scratch.per_ring;
  per_ring.resize((1 + narrow.size()) * nr * nd);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nr, 4), [&](const auto& range) {
    for (size_t q = range.begin(); q != range.end(); ++q) {
      const PixelRing& ring = L.rings[q];
      for (size_t k = 0; k < nd; ++k) {
        const RingAxis& axis = axes[k];
        const double a = axis.d.z * ring.z, bx = ring.r * axis.d.x, by = ring.r * axis.d.y;
        const RingArc arc = arc_above(ring, axis, 0.0);
        lit[q * nd + k] = arc;
        per_ring[q * nd + k] = arc.length ? linear_sum(sums, q, arc, a, bx, by) : 0.0;
        for (size_t i = 0; i < narrow.size(); ++i) {
          const size_t e = narrow[i];
          const RingArc lobe = arc.length && t_min[e] > 0 ? arc_above(ring, axis, t_min[e]) : arc;
          per_ring[((1 + i) * nr + q) * nd + k] =
              lobe.length ? power_sum(sums, q, lobe, a, bx, by, options.glossy_exponents[e]) : 0.0;
        }
      }
    }
  });
  for (size_t q = 0; q < nr; ++q)
    for (size_t k = 0; k < nd; ++k) {
      ref.diffuse[k] += per_ring[q * nd + k];
      for (size_t i = 0; i < narrow.size(); ++i) ref.glossy[narrow[i]][k] += per_ring[((1 + i) * nr + q) * nd + k];
    }
  harmonic_lobe_sums(sums, ref.directions, lit, options.glossy_exponents, ref.glossy, scratch.by_ring);
  for (size_t e = 0; e < ne; ++e) {
    const double norm = (options.glossy_exponents[e] + 1) / (2 * M_PI);
    for (double& v : ref.glossy[e]) v *= norm;
  }

  if (options.shadowed) {
    ref.caps = occluder_caps(options.caps, options.cap_seed);
    const size_t nc = ref.caps.size();
    ref.shadowed.assign(nc, std::vector<double>(nd, 0.0));
    const double cos_half = std::cos(options.cap_half_angle_deg * M_PI / 180.0);
    // Shadowed = diffuse - the irradiance from the pixels inside the cap: on each ring the
    // lit arc of the direction intersected with the cap's arc.
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nc, 1), [&](const auto& range) {
      std::vector<std::pair<size_t, RingArc>> in_cap;
      for (size_t c = range.begin(); c != range.end(); ++c) {
        const RingAxis cap(ref.caps[c]);
        in_cap.clear();
        for (size_t q = 0; q < nr; ++q)
          if (const RingArc arc = cap_arc(map, L, q, cap, cos_half); arc.length) in_cap.emplace_back(q, arc);
        for (size_t k = 0; k < nd; ++k) {
          const Vec3 n = ref.directions[k];
          double occluded = 0;
          for (const auto& [q, arc] : in_cap) {
            const PixelRing& ring = L.rings[q];
            RingArc parts[2];
            const int found = intersect_arcs(lit[q * nd + k], arc, ring.count, parts);
            for (int i = 0; i < found; ++i)
              occluded += linear_sum(sums, q, parts[i], n.z * ring.z, ring.r * n.x, ring.r * n.y);
          }
          ref.shadowed[c][k] = std::max(0.0, ref.diffuse[k] - occluded);
        }
      }
    });
  }
  ref.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return ref;
}

LightError light_error(const AccuracyReference& reference, std::span<const Light> lights) {
  return light_error(reference, lights, Sh9{});
}

LightError light_error(const AccuracyReference& reference, std::span<const Light> lights, const Sh9& ambient) {
  const AccuracyOptions& opt = reference.options;
  const auto& dirs = reference.directions;
  const size_t nd = dirs.size();
  std::vector<double> lum(lights.size());
  for (size_t i = 0; i < lights.size(); ++i) lum[i] = lights[i].luminance();

  LightError err;
  std::vector<double> est(nd);
  for (size_t k = 0; k < nd; ++k) {
    double e = 0;
    for (size_t i = 0; i < lights.size(); ++i) e += lum[i] * std::max(0.0, dot(dirs[k], lights[i].direction));
    est[k] = e + luminance(sh9_irradiance(ambient, dirs[k]).data());
  }
  err.diffuse = rel_rms(reference.diffuse, est);

  const std::vector<double> diffuse_lights = est;
  for (size_t g = 0; g < reference.glossy.size() && g < opt.glossy_exponents.size(); ++g) {
    const double s = opt.glossy_exponents[g];
    for (size_t k = 0; k < nd; ++k) {
      double e = 0;
      for (size_t i = 0; i < lights.size(); ++i) e += lum[i] * phong_lobe(dot(dirs[k], lights[i].direction), s);
      est[k] = e + luminance(sh9_phong(ambient, dirs[k], s).data());
    }
    err.glossy.push_back(rel_rms(reference.glossy[g], est));
  }

  if (opt.shadowed && !reference.shadowed.empty()) {
    // Shadowed = all lights (and the ambient) minus the lights inside the cap.
    const double cos_half = std::cos(opt.cap_half_angle_deg * M_PI / 180.0);
    double sum = 0;
    std::vector<size_t> inside;
    for (size_t c = 0; c < reference.shadowed.size(); ++c) {
      const Vec3 cap = reference.caps[c];
      inside.clear();
      for (size_t i = 0; i < lights.size(); ++i)
        if (dot(cap, lights[i].direction) >= cos_half) inside.push_back(i);
      for (size_t k = 0; k < nd; ++k) {
        double e = 0;
        for (size_t i : inside) e += lum[i] * std::max(0.0, dot(dirs[k], lights[i].direction));
        est[k] = std::max(0.0, diffuse_lights[k] - e);
      }
      sum += rel_rms(reference.shadowed[c], est);
    }
    err.shadowed = sum / double(reference.shadowed.size());
  }
  return err;
}

double map_irradiance(const EnvMap& map, Vec3 normal) {
  double sum = 0;
  const size_t n = map.pixel_count();
  for (size_t i = 0; i < n; ++i) {
    if (!map.is_valid(i)) continue;
    const float* p = map.pixel(i);
    const double y = luminance(p[0], p[1], p[2]);
    if (y == 0) continue;
    const double c = dot(normal, pixel_direction(map, i));
    if (c > 0) sum += y * pixel_solid_angle(map, i) * c;
  }
  return sum;
}

double lights_irradiance(std::span<const Light> lights, Vec3 normal) {
  double sum = 0;
  for (const Light& l : lights) sum += l.luminance() * std::max(0.0, dot(normal, l.direction));
  return sum;
}

double map_glossy(const EnvMap& map, Vec3 reflection, double exponent) {
  double sum = 0;
  const size_t n = map.pixel_count();
  for (size_t i = 0; i < n; ++i) {
    if (!map.is_valid(i)) continue;
    const float* p = map.pixel(i);
    const double y = luminance(p[0], p[1], p[2]);
    if (y == 0) continue;
    sum += y * pixel_solid_angle(map, i) * phong_lobe(dot(reflection, pixel_direction(map, i)), exponent);
  }
  return sum;
}

}  // namespace lp
