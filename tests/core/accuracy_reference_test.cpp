// make_accuracy_reference (integrated on the map's rings, core/pixel_rings.h) against the
// definition of CONVENTIONS.md computed the slow, plain way: every pixel for every
// direction and every cap, in double, with pixel_direction and pixel_solid_angle.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>

#include "core/accuracy.h"
#include "core/image_io.h"
#include "core/pixel_rings.h"

namespace lp {
namespace {

// The definition, pixel by pixel: diffuse sum w max(0, n.d); glossy sum w lobe(r.d);
// shadowed the diffuse sum over the pixels outside the cap (c.d < cos half-angle).
AccuracyReference pixelwise_reference(const EnvMap& map, const AccuracyOptions& options) {
  AccuracyReference ref;
  ref.options = options;
  ref.directions = fibonacci_sphere(options.directions);
  const size_t nd = ref.directions.size(), np = map.pixel_count();
  std::vector<Vec3> dir(np);
  std::vector<double> w(np, 0.0);
  for (size_t i = 0; i < np; ++i) {
    dir[i] = pixel_direction(map, i);
    if (!map.is_valid(i)) continue;
    const float* p = map.pixel(i);
    w[i] = double(luminance(p[0], p[1], p[2])) * pixel_solid_angle(map, i);
  }
  ref.diffuse.assign(nd, 0.0);
  ref.glossy.assign(options.glossy_exponents.size(), std::vector<double>(nd, 0.0));
  for (size_t k = 0; k < nd; ++k)
    for (size_t i = 0; i < np; ++i) {
      const double t = dot(ref.directions[k], dir[i]);
      ref.diffuse[k] += w[i] * std::max(0.0, t);
      for (size_t e = 0; e < options.glossy_exponents.size(); ++e)
        ref.glossy[e][k] += w[i] * phong_lobe(t, options.glossy_exponents[e]);
    }
  if (!options.shadowed) return ref;
  ref.caps = occluder_caps(options.caps, options.cap_seed);
  const double cos_half = std::cos(options.cap_half_angle_deg * M_PI / 180.0);
  for (Vec3 c : ref.caps) {
    std::vector<double> values(nd, 0.0);
    for (size_t i = 0; i < np; ++i) {
      if (dot(c, dir[i]) >= cos_half) continue;
      for (size_t k = 0; k < nd; ++k) values[k] += w[i] * std::max(0.0, dot(ref.directions[k], dir[i]));
    }
    ref.shadowed.push_back(values);
  }
  return ref;
}

// A clear sky brightening towards the zenith, a dark ground, and a sun of a few pixels
// 10^4 times brighter than the sky: the map the yardstick is hardest on.
EnvMap sun_and_sky(EnvMap map) {
  const Vec3 sun = normalize({0.35, -0.6, 0.55});
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    const Vec3 d = pixel_direction(map, i);
    const double sky = d.z > 0 ? 0.5 + 0.8 * d.z : 0.08 + 0.02 * d.x;
    const double disk = dot(d, sun) > std::cos(4.0 * M_PI / 180) ? 4e3 : 0.0;
    map.pixel(i)[0] = float(0.8 * sky + disk);
    map.pixel(i)[1] = float(0.9 * sky + 0.95 * disk);
    map.pixel(i)[2] = float(1.2 * sky + 0.8 * disk);
  }
  return map;
}

// Largest difference over the directions, as a fraction of the mean of the definition's
// values (the scale of rel_rms: an error figure moves by at most about this much).
double worst_difference(const std::vector<double>& fast, const std::vector<double>& slow) {
  EXPECT_EQ(fast.size(), slow.size());
  double worst = 0, mean = 0;
  for (size_t k = 0; k < slow.size(); ++k) {
    worst = std::max(worst, std::fabs(fast[k] - slow[k]));
    mean += slow[k];
  }
  mean /= double(slow.size());
  return mean > 0 ? worst / mean : worst;
}

// Diffuse and shadowed are exact sums (rounding only: 1e-9); glossy leaves out the lobe's
// tail below 1e-10, at most 2 (s+1) 1e-10 of the mean (2e-8 for s = 100): 1e-7.
void expect_same_reference(const EnvMap& map, const AccuracyOptions& options) {
  SCOPED_TRACE(describe_size(map));
  const AccuracyReference fast = make_accuracy_reference(map, options);
  const AccuracyReference slow = pixelwise_reference(map, options);
  ASSERT_EQ(fast.directions.size(), slow.directions.size());
  EXPECT_LT(worst_difference(fast.diffuse, slow.diffuse), 1e-9);
  ASSERT_EQ(fast.glossy.size(), slow.glossy.size());
  for (size_t e = 0; e < slow.glossy.size(); ++e)
    EXPECT_LT(worst_difference(fast.glossy[e], slow.glossy[e]), 1e-7) << "s = " << options.glossy_exponents[e];
  ASSERT_EQ(fast.shadowed.size(), slow.shadowed.size());
  double worst_cap = 0;
  for (size_t c = 0; c < slow.shadowed.size(); ++c)
    worst_cap = std::max(worst_cap, worst_difference(fast.shadowed[c], slow.shadowed[c]));
  EXPECT_LT(worst_cap, 1e-9);
  // And the figures a light list gets from each agree as closely.
  std::vector<Light> lights(3);
  lights[0].direction = normalize({0.35, -0.6, 0.55});
  lights[1].direction = normalize({-0.2, 0.3, 0.9});
  lights[2].direction = normalize({0.1, 0.8, -0.3});
  for (size_t i = 0; i < lights.size(); ++i) lights[i].rgb = {1.0 + double(i), 1.0, 0.5}, lights[i].id = i;
  const LightError a = light_error(fast, lights), b = light_error(slow, lights);
  EXPECT_NEAR(a.diffuse, b.diffuse, 1e-9 * b.diffuse);
  EXPECT_NEAR(a.shadowed, b.shadowed, 1e-9 * b.shadowed);
  for (size_t e = 0; e < b.glossy.size(); ++e) EXPECT_NEAR(a.glossy[e], b.glossy[e], 1e-7 * b.glossy[e]);
}

TEST(AccuracyReference, EqualsThePixelwiseDefinitionOnSunAndSkyInEveryLayout) {
  AccuracyOptions options;  // every measure: 256 directions, s = 10 and 100, 64 caps
  expect_same_reference(sun_and_sky(make_latlong(128, 64)), options);
  expect_same_reference(sun_and_sky(make_hemisphere(120, 30)), options);
  expect_same_reference(sun_and_sky(make_healpix(16)), options);
}

TEST(AccuracyReference, EqualsThePixelwiseDefinitionWithAMaskAndOtherExponents) {
  EnvMap map = sun_and_sky(make_latlong(96, 48));
  map.valid.assign(map.pixel_count(), 1);
  for (size_t i = 0; i < map.pixel_count(); i += 7) map.valid[i] = 0;  // scattered unseen pixels
  AccuracyOptions options;
  options.directions = 100;
  options.glossy_exponents = {1.0, 2.5, 37.0, 400.0};  // pow for 2.5; 400: a lobe of a few pixels
  options.caps = 9;
  options.cap_half_angle_deg = 35;
  expect_same_reference(map, options);
}

TEST(AccuracyReference, EqualsThePixelwiseDefinitionOnSharedProbes) {
  const std::string dir = std::string(LIGHTPROBE_SHARED_DATA) + "/probes-probulator-latlong256/";
  if (!std::filesystem::exists(dir + "grace.hdr")) GTEST_SKIP() << "no shared data";
  AccuracyOptions options;
  options.caps = 12;  // 256 directions and both lobes; fewer caps keep the definition quick
  for (const char* name : {"grace.hdr", "pisa.hdr"}) expect_same_reference(read_envmap(dir + name), options);
}

TEST(AccuracyReference, BlackMapGivesZerosAndNoDirectionsGiveNothing) {
  const AccuracyReference black = make_accuracy_reference(make_latlong(64, 32));
  for (double v : black.diffuse) EXPECT_EQ(v, 0.0);
  for (const auto& cap : black.shadowed)
    for (double v : cap) EXPECT_EQ(v, 0.0);
  AccuracyOptions none;
  none.directions = 0;
  const AccuracyReference empty = make_accuracy_reference(sun_and_sky(make_latlong(64, 32)), none);
  EXPECT_TRUE(empty.diffuse.empty());
}

TEST(PixelRings, EveryPixelOnceWithItsDirectionAndSolidAngle) {
  for (const EnvMap& map :
       {make_latlong(64, 32), make_hemisphere(36, 9), make_healpix(1), make_healpix(8), make_healpix(64)}) {
    SCOPED_TRACE(describe_size(map));
    const auto layout = ring_layout(map);
    std::vector<int> seen(map.pixel_count(), 0);
    for (const PixelRing& ring : layout->rings)
      for (size_t j = 0; j < ring.count; ++j) {
        const size_t i = layout->map_index(ring.first + j);
        ++seen[i];
        const Vec3 d = pixel_direction(map, i);
        const double phi = ring.phi0 + double(j) * ring.dphi;
        EXPECT_NEAR(d.x, ring.r * std::cos(phi), 1e-12);
        EXPECT_NEAR(d.y, ring.r * std::sin(phi), 1e-12);
        EXPECT_NEAR(d.z, ring.z, 1e-12);
        EXPECT_NEAR(layout->cos_phi[ring.table + j], std::cos(phi), 1e-12);
        EXPECT_DOUBLE_EQ(ring.solid_angle, pixel_solid_angle(map, i));
      }
    for (int s : seen) EXPECT_EQ(s, 1);
    EXPECT_EQ(ring_layout(map), layout);  // cached: maps of one size share it
  }
}

TEST(PixelRings, ArcsHoldThePixelsWithinTheHalfAngle) {
  const EnvMap map = make_latlong(16, 8);
  const PixelRing ring = ring_layout(map)->rings[3];  // azimuths (j + 1/2) 2 pi / 16
  auto pixels = [&](RingArc a) {
    std::vector<size_t> out;
    for (size_t j = 0; j < a.length; ++j) out.push_back((a.start + j) % ring.count);
    return out;
  };
  const double step = 2 * M_PI / 16;
  // Around pixel 0's azimuth, 1.2 steps either side: pixels 15, 0, 1 (wrapping).
  EXPECT_EQ(pixels(arc_within(ring, 0.5 * step, 1.2 * step)), (std::vector<size_t>{15, 0, 1}));
  EXPECT_EQ(pixels(arc_within(ring, 4.0 * step, 0.6 * step)), (std::vector<size_t>{3, 4}));
  EXPECT_EQ(arc_within(ring, 1.0, M_PI).length, 16u);
  EXPECT_EQ(arc_within(ring, 1.0, 0.0).length, 0u);
  RingArc parts[2];
  // [14, 14+5) = 14 15 0 1 2 and [1, 1+14) = 1..14: {14} and {1, 2}.
  ASSERT_EQ(intersect_arcs({14, 5}, {1, 14}, 16, parts), 2);
  std::vector<size_t> both = pixels(parts[0]), second = pixels(parts[1]);
  both.insert(both.end(), second.begin(), second.end());
  std::sort(both.begin(), both.end());
  EXPECT_EQ(both, (std::vector<size_t>{1, 2, 14}));
  EXPECT_EQ(intersect_arcs({0, 16}, {5, 3}, 16, parts), 1);
  EXPECT_EQ(parts[0].start, 5u);
  EXPECT_EQ(parts[0].length, 3u);
  EXPECT_EQ(intersect_arcs({0, 4}, {8, 4}, 16, parts), 0);
}

}  // namespace
}  // namespace lp
