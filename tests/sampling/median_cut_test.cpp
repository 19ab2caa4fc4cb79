// Debevec's median cut: one region per light, regions partition the map, exact n.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>

#include "core/envmap.h"
#include "core/error.h"
#include "sampling/sampler.h"

namespace lp {
namespace {

EnvMap random_latlong(int h, uint32_t seed) {
  EnvMap m = make_latlong(2 * h, h);
  std::mt19937 rng(seed);
  std::exponential_distribution<float> e(1.0f);
  for (float& v : m.rgb) v = e(rng);
  // A bright blob so that the power is far from uniform.
  for (int r = h / 4; r < h / 4 + 3; ++r)
    for (int c = h / 2; c < h / 2 + 4; ++c) m.pixel(size_t(r) * m.width + c)[0] = 500.0f;
  return m;
}

std::vector<Light> median_cut(const EnvMap& map, int n) {
  auto s = make_sampler(Method::MedianCut);
  s->prepare(map);
  return s->place(n);
}

TEST(MedianCut, OneLightCarriesTheWholePowerAtThePowerWeightedMeanDirection) {
  const EnvMap map = random_latlong(32, 7);
  const auto lights = median_cut(map, 1);
  ASSERT_EQ(lights.size(), 1u);
  // Independent reference: a plain loop over the pixels.
  Vec3 mean;
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    const float* p = map.pixel(i);
    mean = mean + (luminance(p[0], p[1], p[2]) * pixel_solid_angle(map, i)) * pixel_direction(map, i);
  }
  mean = normalize(mean);
  EXPECT_LT(angle_between(lights[0].direction, mean), 1e-5);
  const auto want = total_power(map);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(lights[0].rgb[c], want[c], 1e-6 * want[c]);
  EXPECT_NEAR(lights[0].solid_angle, 4 * M_PI, 1e-9);
  EXPECT_EQ(lights[0].id, 1u);
}

TEST(MedianCut, RegionsPartitionTheSphere) {
  const EnvMap map = random_latlong(64, 11);
  for (int n : {2, 5, 64, 333}) {
    const auto lights = median_cut(map, n);
    ASSERT_EQ(lights.size(), size_t(n));
    double omega = 0;
    for (const Light& l : lights) {
      EXPECT_GT(l.solid_angle, 0.0);
      omega += l.solid_angle;
    }
    EXPECT_NEAR(omega, 4 * M_PI, 1e-9) << n;
  }
}

TEST(MedianCut, RegionsPartitionTheHemisphere) {
  EnvMap map = make_hemisphere(360, 90);
  for (size_t i = 0; i < map.pixel_count(); ++i) map.pixel(i)[1] = 1.0f + float(i % 13);
  const auto lights = median_cut(map, 100);
  double omega = 0;
  for (const Light& l : lights) {
    omega += l.solid_angle;
    EXPECT_GE(l.direction.z, 0.0);
  }
  EXPECT_NEAR(omega, 2 * M_PI, 1e-9);
}

TEST(MedianCut, IdsAreSplitPathCodes) {
  const EnvMap map = random_latlong(32, 3);
  const auto two = median_cut(map, 2);
  std::set<uint64_t> ids;
  for (const Light& l : two) ids.insert(l.id);
  EXPECT_EQ(ids, (std::set<uint64_t>{2, 3}));
  // With more lights, every id is a distinct node code and no id is an ancestor of another.
  const auto many = median_cut(map, 200);
  std::set<uint64_t> codes;
  for (const Light& l : many) codes.insert(l.id);
  EXPECT_EQ(codes.size(), many.size());
  for (uint64_t c : codes)
    for (uint64_t a = c >> 1; a >= 1; a >>= 1) EXPECT_EQ(codes.count(a), 0u) << c << " under " << a;
}

TEST(MedianCut, FourEqualIsolatedPixelsGetOneLightEach) {
  EnvMap map = make_latlong(1024, 512);
  const size_t pixels[4] = {size_t(100) * 1024 + 200, size_t(150) * 1024 + 700, size_t(350) * 1024 + 400,
                            size_t(400) * 1024 + 900};
  // Equal power: radiance inversely proportional to the pixel's solid angle.
  double each = 0;
  for (size_t p : pixels) {
    const float v = float(1.0 / pixel_solid_angle(map, p));
    for (int k = 0; k < 3; ++k) map.pixel(p)[k] = v;
    each = v * pixel_solid_angle(map, p);
  }
  const auto lights = median_cut(map, 4);
  ASSERT_EQ(lights.size(), 4u);
  std::set<size_t> hit;
  for (const Light& l : lights) {
    double best = 1e9;
    size_t which = 0;
    for (size_t p : pixels) {
      const double a = angle_between(l.direction, pixel_direction(map, p));
      if (a < best) best = a, which = p;
    }
    EXPECT_LT(best, 1e-6);
    hit.insert(which);
    EXPECT_NEAR(l.rgb[0], each, 1e-5 * each);
  }
  EXPECT_EQ(hit.size(), 4u);
}

TEST(MedianCut, AsManyLightsAsPixelsPutsOneLightOnEveryPixelCentre) {
  EnvMap map = make_latlong(8, 4);
  for (size_t i = 0; i < map.pixel_count(); ++i) map.pixel(i)[2] = 1.0f + float(i);
  const auto lights = median_cut(map, 32);
  ASSERT_EQ(lights.size(), 32u);
  std::set<size_t> seen;
  for (const Light& l : lights) {
    const auto p = pixel_at(map, l.direction);
    ASSERT_TRUE(p.has_value());
    EXPECT_LT(angle_between(l.direction, pixel_direction(map, *p)), 1e-6);
    EXPECT_NEAR(l.solid_angle, pixel_solid_angle(map, *p), 1e-12);
    seen.insert(*p);
  }
  EXPECT_EQ(seen.size(), 32u);
  EXPECT_THROW(median_cut(map, 33), InputError);
}

TEST(MedianCut, DarkRegionsStillSplitWhenMoreLightsThanLitPixelsAreAsked) {
  EnvMap map = make_latlong(64, 32);
  for (int k = 0; k < 3; ++k) map.pixel(size_t(5) * 64 + 9)[k] = 10.0f;
  const auto lights = median_cut(map, 50);
  ASSERT_EQ(lights.size(), 50u);
  double omega = 0;
  for (const Light& l : lights) omega += l.solid_angle;
  EXPECT_NEAR(omega, 4 * M_PI, 1e-9);
  const auto want = total_power(map), got = total_power(lights);
  EXPECT_NEAR(got[0], want[0], 1e-6 * want[0]);
}

TEST(MedianCut, AHealpixMapIsCutOnItsRowGridWithItsPowerKept) {
  EnvMap map = make_healpix(16);
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    const Vec3 d = pixel_direction(map, i);
    map.pixel(i)[0] = float(1 + d.z);
    map.pixel(i)[1] = float(1 + d.y);
    map.pixel(i)[2] = 0.2f;
  }
  const auto lights = median_cut(map, 64);
  ASSERT_EQ(lights.size(), 64u);
  const auto want = total_power(map), got = total_power(lights);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], want[c], 1e-5 * want[c]);
}

TEST(MedianCut, InvalidPixelsCarryNoPower) {
  EnvMap map = random_latlong(32, 5);
  map.valid.assign(map.pixel_count(), 1);
  for (size_t i = map.pixel_count() / 2; i < map.pixel_count(); ++i) map.valid[i] = 0;
  const auto lights = median_cut(map, 40);
  const auto want = total_power(map), got = total_power(lights);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], want[c], 1e-5 * want[c]);
  for (const Light& l : lights) {
    if (l.luminance() > 0) {
      EXPECT_GE(l.direction.z, -1e-12);
    }
  }
}

}  // namespace
}  // namespace lp
