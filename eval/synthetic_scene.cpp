#include "eval/synthetic_scene.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "core/healpix.h"

namespace lp {

namespace {

using Rgb = std::array<double, 3>;

double deg(double d) { return d * M_PI / 180.0; }

double smoothstep(double e0, double e1, double x) {
  const double t = std::clamp((x - e0) / (e1 - e0), 0.0, 1.0);
  return t * t * (3 - 2 * t);
}

// Two unit vectors completing `n` to a right-handed orthonormal frame.
void basis(Vec3 n, Vec3& t1, Vec3& t2) {
  const Vec3 a = std::fabs(n.z) < 0.9 ? Vec3{0, 0, 1} : Vec3{1, 0, 0};
  t1 = normalize(cross(a, n));
  t2 = cross(n, t1);
}

// The sky: zenith blue brightening to a pale horizon, a warm glow around the sun; a dim
// grey-brown ground below, blended over about +-1 deg so the horizon is smooth.
constexpr Rgb kZenith{0.3, 0.5, 1.0};
constexpr Rgb kHorizon{0.85, 0.9, 1.0};
constexpr Rgb kGlow{0.6, 0.4, 0.15};
constexpr Rgb kGround{0.12, 0.10, 0.08};

// Number of nested HEALPix levels for about k x k sub-samples per pixel (k rounded down
// to a power of two, since NESTED children come in 4^level).
int healpix_levels(int k) {
  int level = 0;
  while ((2 << level) <= k) ++level;
  return level;
}

}  // namespace

std::array<double, 3> SceneDescription::sun_power() const {
  const double omega = 2 * M_PI * (1 - std::cos(deg(options.sun_radius_deg)));
  return {options.sun_rgb[0] * omega, options.sun_rgb[1] * omega, options.sun_rgb[2] * omega};
}

SceneDescription describe_scene(const SceneOptions& options) {
  SceneDescription s;
  s.options = options;
  s.options.sun_direction = normalize(options.sun_direction);
  if (options.area_lights) {
    const double k = options.sky_scale;
    // Two windows low in the sky at different azimuths, and a small bright lamp higher up.
    s.emitters.push_back({direction_from_angles(deg(72), deg(140)), 7.0, {30 * k, 32 * k, 36 * k}});
    s.emitters.push_back({direction_from_angles(deg(78), deg(245)), 6.0, {24 * k, 24 * k, 27 * k}});
    s.emitters.push_back({direction_from_angles(deg(25), deg(300)), 2.0, {450 * k, 400 * k, 320 * k}});
  }
  return s;
}

std::array<double, 3> scene_radiance_without_sun(const SceneDescription& scene, Vec3 d) {
  Rgb out{0, 0, 0};
  const double k = scene.options.sky_scale;
  if (k != 0) {
    const double z = d.z;
    const double up = std::max(0.0, z);
    const double h = std::pow(1.0 - up, 3.0);  // 0 at the zenith, 1 at the horizon
    const double glow = std::exp((dot(d, scene.options.sun_direction) - 1.0) / 0.05);
    const double sky_weight = smoothstep(-0.02, 0.02, z);
    for (int c = 0; c < 3; ++c) {
      const double sky = kZenith[c] * (1 - h) + kHorizon[c] * h + kGlow[c] * glow;
      out[c] = k * (sky_weight * sky + (1 - sky_weight) * kGround[c]);
    }
  }
  for (const SceneEmitter& e : scene.emitters) {
    if (dot(d, e.direction) >= std::cos(deg(e.half_angle_deg)))
      for (int c = 0; c < 3; ++c) out[c] += e.rgb[c];
  }
  return out;
}

EnvMap render_scene(const SceneDescription& scene, Layout layout, int width, int height) {
  EnvMap map = make_envmap(layout, width, height);
  const int k = std::max(1, scene.options.samples_per_edge);
  const size_t n = map.pixel_count();

  // Smooth part: the average of k x k equal-area sub-samples per pixel.
  if (layout == Layout::Healpix) {
    const int levels = healpix_levels(k);
    const int64_t sub_nside = int64_t(map.nside) << levels;
    const int64_t children = int64_t(1) << (2 * levels);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 256), [&](const auto& r) {
      for (size_t p = r.begin(); p != r.end(); ++p) {
        Rgb sum{0, 0, 0};
        for (int64_t j = 0; j < children; ++j) {
          const Rgb L = scene_radiance_without_sun(scene, healpix_direction(sub_nside, int64_t(p) * children + j));
          for (int c = 0; c < 3; ++c) sum[c] += L[c];
        }
        for (int c = 0; c < 3; ++c) map.pixel(p)[c] = float(sum[c] / double(children));
      }
    });
  } else {
    const double span = layout == Layout::Hemisphere ? M_PI / 2 : M_PI;
    tbb::parallel_for(tbb::blocked_range<int>(0, map.height, 1), [&](const auto& r) {
      for (int v = r.begin(); v != r.end(); ++v) {
        const double c0 = std::cos(span * v / map.height), c1 = std::cos(span * (v + 1) / map.height);
        for (int u = 0; u < map.width; ++u) {
          Rgb sum{0, 0, 0};
          for (int a = 0; a < k; ++a) {
            const double cz = c0 + (c1 - c0) * (a + 0.5) / k;  // cos theta uniform: equal areas
            const double sz = std::sqrt(std::max(0.0, 1 - cz * cz));
            for (int b = 0; b < k; ++b) {
              const double phi = 2 * M_PI * (u + (b + 0.5) / k) / map.width;
              const Rgb L = scene_radiance_without_sun(scene, {sz * std::cos(phi), sz * std::sin(phi), cz});
              for (int c = 0; c < 3; ++c) sum[c] += L[c];
            }
          }
          float* px = map.pixel(size_t(v) * size_t(map.width) + size_t(u));
          for (int c = 0; c < 3; ++c) px[c] = float(sum[c] / double(k * k));
        }
      }
    });
  }

  // Sun: its disc integrated exactly. 64 x 64 equal-area strata over the disc (cos of the
  // angle from the centre and the azimuth around it uniform), each carrying 1/4096 of the
  // analytic power, deposited into the pixel containing it as radiance = power / omega.
  const Rgb power = scene.sun_power();
  if (power[0] != 0 || power[1] != 0 || power[2] != 0) {
    constexpr int kSide = 64;
    const Vec3 s = scene.options.sun_direction;
    Vec3 t1, t2;
    basis(s, t1, t2);
    const double cos_r = std::cos(deg(scene.options.sun_radius_deg));
    const double share = 1.0 / double(kSide * kSide);
    std::vector<size_t> hits;  // pixel of every sample; counted per pixel, then one float write
    hits.reserve(kSide * kSide);
    for (int a = 0; a < kSide; ++a) {
      const double ca = 1 - (1 - cos_r) * (a + 0.5) / kSide;
      const double sa = std::sqrt(std::max(0.0, 1 - ca * ca));
      for (int b = 0; b < kSide; ++b) {
        const double beta = 2 * M_PI * (b + 0.5) / kSide;
        const Vec3 d = ca * s + (sa * std::cos(beta)) * t1 + (sa * std::sin(beta)) * t2;
        const auto p = pixel_at(map, d);
        if (!p) continue;  // below a hemisphere map's horizon
        hits.push_back(*p);
      }
    }
    std::sort(hits.begin(), hits.end());
    for (size_t i = 0; i < hits.size();) {
      size_t j = i;
      while (j < hits.size() && hits[j] == hits[i]) ++j;
      const size_t p = hits[i];
      const double omega = pixel_solid_angle(map, p);
      const double f = double(j - i) * share / omega;
      for (int c = 0; c < 3; ++c) map.pixel(p)[c] = float(double(map.pixel(p)[c]) + power[c] * f);
      i = j;
    }
  }
  return map;
}

}  // namespace lp
