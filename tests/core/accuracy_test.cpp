#include "core/accuracy.h"

#include <gtest/gtest.h>

#include <cmath>

namespace lp {
namespace {

constexpr double kPi = M_PI;

EnvMap constant_map(EnvMap map, float radiance) {
  for (float& v : map.rgb) v = radiance;
  return map;
}

// Upper hemisphere at `radiance`, the rest black. HEALPix has a ring of pixels centred on
// the horizon (z = 0), half above and half below: they get half the radiance.
EnvMap upper_hemisphere_map(EnvMap map, float radiance) {
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    const double z = pixel_direction(map, i).z;
    const float v = z > 1e-12 ? radiance : z > -1e-12 ? radiance / 2 : 0.0f;
    for (int c = 0; c < 3; ++c) map.pixel(i)[c] = v;
  }
  return map;
}

// Relative tolerance of pixel-centre quadrature of the cosine lobe: 1e-4, except that on
// HEALPix the centre rule is off by exactly 1/(9 nside^2) for a normal along the pole axis
// (1.09e-4 at nside 32, 2.7e-5 at nside 64) -- a property of the layout, not of the code.
double quadrature_tolerance(const EnvMap& map) {
  return map.layout == Layout::Healpix ? std::max(1e-4, 1.05 / (9.0 * map.nside * map.nside)) : 1e-4;
}

// One light per pixel: the map itself as a light list.
std::vector<Light> lights_from_pixels(const EnvMap& map) {
  std::vector<Light> lights;
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    const double omega = pixel_solid_angle(map, i);
    Light l;
    l.id = i;
    l.direction = pixel_direction(map, i);
    for (int c = 0; c < 3; ++c) l.rgb[c] = double(map.pixel(i)[c]) * omega;
    l.solid_angle = omega;
    lights.push_back(l);
  }
  return lights;
}

// A smooth map with some structure: a sky gradient and a bright spot.
EnvMap structured_map(EnvMap map) {
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    const Vec3 d = pixel_direction(map, i);
    const double spot = std::exp((dot(d, normalize(Vec3{0.3, -0.5, 0.6})) - 1) / 0.01);
    map.pixel(i)[0] = float(0.2 + 0.5 * std::max(0.0, d.z) + 40 * spot);
    map.pixel(i)[1] = float(0.3 + 0.4 * std::max(0.0, d.z) + 35 * spot);
    map.pixel(i)[2] = float(0.4 + 0.3 * std::max(0.0, d.z) + 20 * spot);
  }
  return map;
}

const Vec3 kNormals[] = {{0, 0, 1}, {0, 0, -1}, {1, 0, 0}, {0.6, 0.0, 0.8}, {-0.48, 0.6, -0.64},
                         {0.267261, 0.534522, 0.801784}};

TEST(Accuracy, ConstantSphereGivesPiLIrradianceEverywhere) {
  const float L = 2.5f;
  for (const EnvMap& map : {constant_map(make_latlong(256, 128), L), constant_map(make_healpix(32), L),
                            constant_map(make_healpix(64), L)}) {
    SCOPED_TRACE(describe_size(map));
    const double tol = quadrature_tolerance(map);
    for (Vec3 n : kNormals) EXPECT_NEAR(map_irradiance(map, normalize(n)) / (kPi * L), 1.0, tol);
    AccuracyOptions opt;
    opt.caps = 8;
    const AccuracyReference ref = make_accuracy_reference(map, opt);
    ASSERT_EQ(ref.diffuse.size(), 256u);
    for (double e : ref.diffuse) EXPECT_NEAR(e / (kPi * L), 1.0, tol);
  }
}

TEST(Accuracy, ConstantUpperHemisphereLightsUpFacingNormalsOnly) {
  const float L = 3.0f;
  for (const EnvMap& map :
       {upper_hemisphere_map(make_latlong(256, 128), L), upper_hemisphere_map(make_healpix(32), L)}) {
    SCOPED_TRACE(describe_size(map));
    const double tol = quadrature_tolerance(map);
    EXPECT_NEAR(map_irradiance(map, {0, 0, 1}) / (kPi * L), 1.0, tol);
    EXPECT_EQ(map_irradiance(map, {0, 0, -1}), 0.0);
    // Horizontal: half the cosine lobe sees the sky.
    EXPECT_NEAR(map_irradiance(map, {1, 0, 0}) / (kPi * L / 2), 1.0, tol);
    EXPECT_NEAR(map_irradiance(map, normalize({1, 1, 0})) / (kPi * L / 2), 1.0, tol);
  }
}

TEST(Accuracy, HemisphereLayoutSeesOnlyTheUpperHalf) {
  const EnvMap map = constant_map(make_hemisphere(360, 90), 1.0f);
  EXPECT_NEAR(map_irradiance(map, {0, 0, 1}) / kPi, 1.0, 1e-4);
  EXPECT_NEAR(map_irradiance(map, {0, 1, 0}) / (kPi / 2), 1.0, 1e-4);
  EXPECT_EQ(map_irradiance(map, {0, 0, -1}), 0.0);
  AccuracyOptions opt;
  opt.shadowed = false;
  const AccuracyReference ref = make_accuracy_reference(map, opt);
  for (size_t k = 0; k < ref.directions.size(); ++k)
    EXPECT_NEAR(ref.diffuse[k], map_irradiance(map, ref.directions[k]), 1e-5 * kPi);
}

TEST(Accuracy, PhongLobeIntegratesToOneOverTheSphere) {
  for (double s : {1.0, 10.0, 100.0}) {
    // Over the sphere around the lobe axis: 2 pi int_0^pi lobe(cos t) sin t dt, Simpson's rule.
    const int n = 200000;
    const double h = kPi / n;
    double sum = 0;
    for (int i = 0; i <= n; ++i) {
      const double t = i * h;
      const double f = phong_lobe(std::cos(t), s) * std::sin(t);
      sum += f * (i == 0 || i == n ? 1 : (i % 2 ? 4 : 2));
    }
    EXPECT_NEAR(2 * kPi * sum * h / 3, 1.0, 1e-4) << "s = " << s;
    // And on a map: a constant unit sphere reflects exactly 1 through the lobe.
    const EnvMap map = constant_map(make_latlong(2048, 1024), 1.0f);
    EXPECT_NEAR(map_glossy(map, normalize({0.2, 0.3, 0.9}), s), 1.0, 1e-4) << "s = " << s;
  }
}

TEST(Accuracy, PhongLobeMatchesItsFormula) {
  for (double s : {1.0, 2.5, 10.0, 100.0})
    for (double c : {0.0, 0.1, 0.5, 0.9, 0.999, 1.0})
      EXPECT_DOUBLE_EQ(phong_lobe(c, s), (s + 1) / (2 * kPi) * std::pow(c, s));
  EXPECT_EQ(phong_lobe(-0.3, 10), 0.0);
}

TEST(Accuracy, FibonacciSpherePointsAreUnitAndBalanced) {
  for (int count : {1, 7, 256, 1000}) {
    const auto pts = fibonacci_sphere(count);
    ASSERT_EQ(pts.size(), size_t(count));
    Vec3 mean;
    for (Vec3 p : pts) {
      EXPECT_NEAR(length(p), 1.0, 1e-12);
      mean = mean + p;
    }
    if (count >= 256) { EXPECT_LT(length((1.0 / count) * mean), 0.01); }
  }
  EXPECT_TRUE(fibonacci_sphere(0).empty());
  // First and last points straddle the poles symmetrically.
  const auto pts = fibonacci_sphere(256);
  EXPECT_DOUBLE_EQ(pts.front().z, 1 - 1.0 / 256);
  EXPECT_DOUBLE_EQ(pts.back().z, -(1 - 1.0 / 256));
}

TEST(Accuracy, OccluderCapsAreDeterministicForASeed) {
  const auto a = occluder_caps(64, 20051), b = occluder_caps(64, 20051), c = occluder_caps(64, 7);
  ASSERT_EQ(a.size(), 64u);
  Vec3 mean;
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].x, b[i].x);
    EXPECT_EQ(a[i].y, b[i].y);
    EXPECT_EQ(a[i].z, b[i].z);
    EXPECT_NEAR(length(a[i]), 1.0, 1e-12);
    mean = mean + a[i];
  }
  EXPECT_NE(a[0].x, c[0].x);
  EXPECT_LT(length((1.0 / 64) * mean), 0.3);  // uniform: 64 points average near the centre
}

TEST(Accuracy, ReferenceAgreesWithDirectDoubleIntegration) {
  const EnvMap map = structured_map(make_latlong(128, 64));
  const AccuracyReference ref = make_accuracy_reference(map);
  for (size_t k = 0; k < ref.directions.size(); k += 17) {
    const Vec3 n = ref.directions[k];
    EXPECT_NEAR(ref.diffuse[k] / map_irradiance(map, n), 1.0, 1e-5);
    EXPECT_NEAR(ref.glossy[0][k] / map_glossy(map, n, 10), 1.0, 1e-5);
    const double g100 = map_glossy(map, n, 100);
    EXPECT_NEAR(ref.glossy[1][k], g100, 1e-5 * g100 + 1e-9);
  }
}

TEST(Accuracy, LightsMadeFromEveryPixelScoreZeroError) {
  for (const EnvMap& map : {structured_map(make_latlong(128, 64)), structured_map(make_healpix(16))}) {
    SCOPED_TRACE(describe_size(map));
    const AccuracyReference ref = make_accuracy_reference(map);
    const auto lights = lights_from_pixels(map);
    const LightError e = light_error(ref, lights);
    EXPECT_LT(e.diffuse, 1e-5);
    ASSERT_EQ(e.glossy.size(), 2u);
    EXPECT_LT(e.glossy[0], 1e-5);
    EXPECT_LT(e.glossy[1], 1e-5);
    EXPECT_LT(e.shadowed, 1e-5);
  }
}

TEST(Accuracy, LightsTenPercentTooBrightScoreTenPercentDiffuseError) {
  const EnvMap map = structured_map(make_latlong(128, 64));
  const AccuracyReference ref = make_accuracy_reference(map);
  auto lights = lights_from_pixels(map);
  for (Light& l : lights)
    for (double& c : l.rgb) c *= 1.1;
  const LightError e = light_error(ref, lights);
  // Every E_lights is 1.1 E_ref: rel_rms = 0.1 * rms(E_ref) / mean(E_ref) >= 0.1, and equal
  // to 0.1 times the ratio of the quadratic to the arithmetic mean.
  double sq = 0, mean = 0;
  for (double v : ref.diffuse) {
    sq += v * v;
    mean += v;
  }
  const double n = double(ref.diffuse.size());
  EXPECT_NEAR(e.diffuse, 0.1 * std::sqrt(sq / n) / (mean / n), 1e-6);
  EXPECT_GE(e.diffuse, 0.1 - 1e-9);
}

TEST(Accuracy, ConstantMapScaledByElevenTenthsScoresExactlyATenth) {
  const EnvMap map = constant_map(make_latlong(128, 64), 1.0f);
  AccuracyOptions opt;
  opt.shadowed = false;
  const AccuracyReference ref = make_accuracy_reference(map, opt);
  auto lights = lights_from_pixels(map);
  for (Light& l : lights)
    for (double& c : l.rgb) c *= 1.1;
  EXPECT_NEAR(light_error(ref, lights).diffuse, 0.1, 1e-4);
}

TEST(Accuracy, OneLightWithTheRightPowerInTheWrongPlaceScoresBadly) {
  const EnvMap map = structured_map(make_latlong(128, 64));
  const AccuracyReference ref = make_accuracy_reference(map);
  Light l;
  l.direction = normalize({-0.3, 0.5, -0.6});  // opposite the bright spot
  l.rgb = total_power(map);
  const Light lights[] = {l};
  const LightError e = light_error(ref, lights);
  EXPECT_GT(e.diffuse, 0.5);
  EXPECT_GT(e.glossy[0], 0.5);
  EXPECT_GT(e.shadowed, 0.5);
}

TEST(Accuracy, CapsOverTheOnlyBrightPixelLeaveTheRestOfTheMap) {
  EnvMap map = constant_map(make_latlong(128, 64), 1.0f);
  const size_t bright = 20 * 128 + 37;
  const Vec3 bright_dir = pixel_direction(map, bright);
  for (int c = 0; c < 3; ++c) map.pixel(bright)[c] = 1000.0f;
  const AccuracyReference ref = make_accuracy_reference(map);
  // The rest of the map: the same map with the bright pixel at the background level.
  EnvMap rest = map;
  for (int c = 0; c < 3; ++c) rest.pixel(bright)[c] = 1.0f;
  int covering = 0;
  const double cos_half = std::cos(60.0 * kPi / 180);
  std::vector<Vec3> dirs(map.pixel_count());
  std::vector<double> omegas(map.pixel_count());
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    dirs[i] = pixel_direction(map, i);
    omegas[i] = pixel_solid_angle(map, i);
  }
  for (size_t c = 0; c < ref.caps.size(); ++c) {
    if (dot(ref.caps[c], bright_dir) < cos_half) continue;
    ++covering;
    for (size_t k = 0; k < ref.directions.size(); k += 5) {
      const Vec3 n = ref.directions[k];
      // Without the cap: the whole map minus what lies inside the cap (unit background).
      double in_cap = 0;
      for (size_t i = 0; i < map.pixel_count(); ++i)
        if (dot(ref.caps[c], dirs[i]) >= cos_half) in_cap += omegas[i] * std::max(0.0, dot(n, dirs[i]));
      // The bright pixel is inside the cap, so whatever it adds is gone.
      const double expected = map_irradiance(rest, n) - in_cap;
      EXPECT_NEAR(ref.shadowed[c][k], expected, 1e-4 * kPi) << "cap " << c << " normal " << k;
    }
  }
  EXPECT_GT(covering, 0);
}

TEST(Accuracy, SkippingShadowedLeavesItEmptyAndZero) {
  const EnvMap map = structured_map(make_latlong(64, 32));
  AccuracyOptions opt;
  opt.shadowed = false;
  const AccuracyReference ref = make_accuracy_reference(map, opt);
  EXPECT_TRUE(ref.shadowed.empty());
  EXPECT_EQ(light_error(ref, lights_from_pixels(map)).shadowed, 0.0);
}

TEST(Accuracy, InvalidPixelsDoNotCount) {
  EnvMap map = constant_map(make_latlong(64, 32), 1.0f);
  map.valid.assign(map.pixel_count(), 1);
  for (size_t i = 0; i < map.pixel_count(); ++i)
    if (pixel_direction(map, i).z < 0) map.valid[i] = 0;
  EXPECT_EQ(map_irradiance(map, {0, 0, -1}), 0.0);
  AccuracyOptions opt;
  opt.shadowed = false;
  const AccuracyReference ref = make_accuracy_reference(map, opt);
  // The same map with the invalid half black instead gives the same reference.
  EnvMap black = map;
  black.valid.clear();
  for (size_t i = 0; i < map.pixel_count(); ++i)
    if (!map.valid[i])
      for (int c = 0; c < 3; ++c) black.pixel(i)[c] = 0;
  for (size_t i = 0; i < map.pixel_count(); ++i)
    if (!map.valid[i]) map.pixel(i)[0] = 1e6f;  // garbage under the mask changes nothing
  const AccuracyReference masked = make_accuracy_reference(map, opt);
  const AccuracyReference zeroed = make_accuracy_reference(black, opt);
  for (size_t k = 0; k < ref.diffuse.size(); ++k) {
    EXPECT_DOUBLE_EQ(masked.diffuse[k], zeroed.diffuse[k]);
    EXPECT_DOUBLE_EQ(ref.diffuse[k], zeroed.diffuse[k]);
  }
}

TEST(Accuracy, LightsIrradianceSumsCosineWeightedLuminance) {
  Light a, b;
  a.direction = {0, 0, 1};
  a.rgb = {1, 1, 1};
  b.direction = {1, 0, 0};
  b.rgb = {2, 0, 0};
  const Light lights[] = {a, b};
  EXPECT_NEAR(lights_irradiance(lights, normalize({1, 0, 1})), (1 + 2 * 0.2126) / std::sqrt(2.0), 1e-12);
  EXPECT_EQ(lights_irradiance(lights, {0, 0, -1}), 0.0);
}

}  // namespace
}  // namespace lp
