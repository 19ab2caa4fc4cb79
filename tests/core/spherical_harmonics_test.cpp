// SH9 against closed forms: a constant sky, a clamped-cosine lobe, a single pixel, the
// brute-force irradiance of a smooth map, and the Y-up frame three.js reads.
#include "core/spherical_harmonics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/accuracy.h"
#include "core/error.h"
#include "core/light_list.h"

namespace lp {
namespace {

// A grey latlong map of `height` rows with radiance f(d).
template <class F>
EnvMap grey_map(int height, F f) {
  EnvMap map = make_latlong(2 * height, height);
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    const float v = float(f(pixel_direction(map, i)));
    map.pixel(i)[0] = map.pixel(i)[1] = map.pixel(i)[2] = v;
  }
  return map;
}

// three.js r187 SphericalHarmonics3.getAt / getIrradianceAt (src/math/SphericalHarmonics3.js),
// transcribed for one channel with its own constants: evaluated in three.js' frame.
double threejs_get_at(const std::array<double, 9>& c, Vec3 n) {
  const double x = n.x, y = n.y, z = n.z;
  return c[0] * 0.282095 + c[1] * 0.488603 * y + c[2] * 0.488603 * z + c[3] * 0.488603 * x +
         c[4] * 1.092548 * (x * y) + c[5] * 1.092548 * (y * z) + c[6] * 0.315392 * (3.0 * z * z - 1.0) +
         c[7] * 1.092548 * (x * z) + c[8] * 0.546274 * (x * x - y * y);
}
double threejs_irradiance_at(const std::array<double, 9>& c, Vec3 n) {
  const double x = n.x, y = n.y, z = n.z;
  return c[0] * 0.886227 + c[1] * 2.0 * 0.511664 * y + c[2] * 2.0 * 0.511664 * z + c[3] * 2.0 * 0.511664 * x +
         c[4] * 2.0 * 0.429043 * x * y + c[5] * 2.0 * 0.429043 * y * z + c[6] * (0.743125 * z * z - 0.247708) +
         c[7] * 2.0 * 0.429043 * x * z + c[8] * 0.429043 * (x * x - y * y);
}
std::array<double, 9> channel(const Sh9& sh, int c) {
  std::array<double, 9> out{};
  for (int k = 0; k < 9; ++k) out[k] = sh.coefficients[k][c];
  return out;
}

Vec3 random_direction(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  return normalize(Vec3{g(rng), g(rng), g(rng)});
}

TEST(SphericalHarmonics, ConstantRadianceHasOnlyL00) {
  const double radiance = 2.5;
  const Sh9 sh = project_sh9(grey_map(128, [&](Vec3) { return radiance; }));
  // L00 = 4 pi Y00 L = sqrt(4 pi) L: the solid angles are exact, so only float rounding.
  EXPECT_NEAR(sh.coefficients[0][1], std::sqrt(4 * M_PI) * radiance, 1e-6);
  // Odd and azimuthal terms cancel by symmetry; Y20 only to the midpoint rule's
  // O(1/H^2) over 128 rows.
  for (int k = 1; k < 9; ++k) EXPECT_NEAR(sh.coefficients[k][1], 0.0, k == 6 ? 1e-3 : 1e-6) << k;  // Y20: 5e-4
  EXPECT_NEAR(sh9_power(sh)[2], 4 * M_PI * radiance, 1e-5);
  EXPECT_NEAR(sh9_irradiance(sh, {0.3, -0.4, std::sqrt(0.75)})[0], M_PI * radiance, 1e-3);
}

TEST(SphericalHarmonics, ClampedCosineLobeMatchesClosedForm) {
  // L = max(0, z): L00 = c00 pi, L10 = c1 (2 pi / 3), L20 = c20 (pi / 2), with the constants
  // c00 = 0.282095, c1 = 0.488603, c20 = 0.315392 (exact forms below).
  const Sh9 sh = project_sh9(grey_map(256, [](Vec3 d) { return std::max(0.0, d.z); }));
  const double y0 = 0.5 / std::sqrt(M_PI), y1 = std::sqrt(3 / M_PI) / 2, y20 = std::sqrt(5 / M_PI) / 4;
  const double expected[9] = {y0 * M_PI, 0, y1 * 2 * M_PI / 3, 0, 0, 0, y20 * M_PI / 2, 0, 0};
  for (int k = 0; k < 9; ++k) EXPECT_NEAR(sh.coefficients[k][0], expected[k], 5e-5) << k;  // midpoint rule: < 2e-5
}

TEST(SphericalHarmonics, SingleBrightPixelGivesTheBasisTimesItsPower) {
  EnvMap map = make_latlong(64, 32);
  const size_t pixel = 9 * 64 + 21;
  map.pixel(pixel)[0] = 1000;
  map.pixel(pixel)[1] = 500;
  map.pixel(pixel)[2] = 10;
  const Sh9 sh = project_sh9(map);
  const auto y = sh9_basis(pixel_direction(map, pixel));
  const double dw = pixel_solid_angle(map, pixel);
  for (int k = 0; k < 9; ++k) {
    EXPECT_NEAR(sh.coefficients[k][0], y[k] * 1000 * dw, 1e-12) << k;
    EXPECT_NEAR(sh.coefficients[k][2], y[k] * 10 * dw, 1e-12) << k;
  }
}

// The row-separable projection of latlong and hemisphere maps against the definition:
// every valid pixel's basis at its own direction, times its radiance and solid angle.
TEST(SphericalHarmonics, RowMapsEqualThePerPixelProjection) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> radiance(0.0f, 50.0f);
  for (const Layout layout : {Layout::LatLong, Layout::Hemisphere}) {
    EnvMap map = make_envmap(layout, 96, layout == Layout::LatLong ? 48 : 24);
    map.valid.assign(map.pixel_count(), 1);
    for (size_t i = 0; i < map.pixel_count(); ++i) {
      for (int c = 0; c < 3; ++c) map.pixel(i)[c] = radiance(rng);
      if (i % 7 == 3) map.valid[i] = 0, map.pixel(i)[0] = 1e30f;  // masked: never read
    }
    Sh9 reference;
    for (size_t i = 0; i < map.pixel_count(); ++i) {
      if (!map.valid[i]) continue;
      const auto y = sh9_basis(pixel_direction(map, i));
      for (int k = 0; k < 9; ++k)
        for (int c = 0; c < 3; ++c) reference.coefficients[k][c] += map.pixel(i)[c] * y[k] * pixel_solid_angle(map, i);
    }
    const Sh9 sh = project_sh9(map);
    for (int k = 0; k < 9; ++k)
      for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(sh.coefficients[k][c], reference.coefficients[k][c], 1e-12 * std::abs(reference.coefficients[0][c]))
            << to_string(layout) << " k " << k << " c " << c;
  }
}

TEST(SphericalHarmonics, IrradianceOfASmoothMapMatchesBruteForce) {
  // L = exp(2 d.s): a broad lobe, not band-limited. Its radiance is sum (2l+1) i_l(2) P_l;
  // the clamped cosine kills l = 3 and SH9 drops l = 4 onwards, whose largest term is
  // A4 9 i_4(2) = (pi/24) 9 0.0201 = 0.024 against a mean irradiance pi i_0(2) = 5.70:
  // 0.4 %. l = 6 adds ~1e-5. So within 0.6 % of the brute-force integral everywhere.
  const Vec3 s = normalize(Vec3{0.3, -0.5, 0.8});
  const EnvMap map = grey_map(128, [&](Vec3 d) { return std::exp(2 * dot(d, s)); });
  const Sh9 sh = project_sh9(map);
  double worst = 0;
  for (Vec3 n : fibonacci_sphere(64)) {
    const double ref = map_irradiance(map, n);
    worst = std::max(worst, std::fabs(sh9_irradiance(sh, n)[0] - ref) / (M_PI * std::sinh(2.0) / 2));
  }
  EXPECT_LT(worst, 0.006);
  EXPECT_GT(worst, 1e-4);  // not band-limited: the truncation shows
}

TEST(SphericalHarmonics, YupCoefficientsGiveThreejsTheSameRadianceAndIrradiance) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  Sh9 sh;
  for (auto& row : sh.coefficients)
    for (double& v : row) v = u(rng);
  const Sh9 yup = sh9_yup_from_zup(sh);
  for (int trial = 0; trial < 200; ++trial) {
    const Vec3 d = random_direction(rng);
    const Vec3 t{d.x, d.z, -d.y};  // the same direction in glTF / three.js' Y-up world
    for (int c = 0; c < 3; ++c) {
      // three.js rounds Y_lm to 6 digits (ours are exact): ~1e-6 of coefficients <= 1;
      // and A_l Y_lm (0.886227, 0.511664, ...) too.
      EXPECT_NEAR(threejs_get_at(channel(yup, c), t), sh9_radiance(sh, d)[c], 5e-6);
      EXPECT_NEAR(threejs_irradiance_at(channel(yup, c), t), sh9_irradiance(sh, d)[c], 2e-5);
    }
  }
}

TEST(SphericalHarmonics, AmbientScoresAsTheYardstickOfABandLimitedMap) {
  // L = 1 + 0.5 z + 0.3 (x^2 - y^2) is exactly SH9, so its SH irradiance and its radiance
  // through the Phong lobes (Funk-Hecke factors) match the pixel-by-pixel reference to
  // the midpoint rule's error; an unshadowed ambient cannot follow an occluding cap.
  const EnvMap map = grey_map(128, [](Vec3 d) { return 1 + 0.5 * d.z + 0.3 * (d.x * d.x - d.y * d.y); });
  AccuracyOptions options;
  options.caps = 8;
  const AccuracyReference ref = make_accuracy_reference(map, options);
  const LightError sh_only = light_error(ref, {}, project_sh9(map));
  EXPECT_LT(sh_only.diffuse, 2e-4);
  EXPECT_LT(sh_only.glossy[0], 5e-4);
  EXPECT_LT(sh_only.glossy[1], 5e-3);  // s = 100 against 256 x 128 pixels of 1.4 deg
  // A 60 deg cap hides 1/4 of the sphere's solid angle, about 1/4 of E where it matters.
  EXPECT_GT(sh_only.shadowed, 0.1);
  // No ambient: the lights' score is unchanged.
  Light sun;
  sun.direction = {0, 0, 1};
  sun.rgb = {4, 4, 4};
  const std::vector<Light> lights{sun};
  EXPECT_EQ(light_error(ref, lights).diffuse, light_error(ref, lights, Sh9{}).diffuse);
}

TEST(SphericalHarmonics, BadMapsAreRefusedNamingTheSource) {
  EnvMap map = make_latlong(16, 8);
  map.valid.assign(map.pixel_count(), 0);
  try {
    project_sh9(map, "dark.exr");
    FAIL() << "no valid pixels accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("dark.exr: no valid pixels"), std::string::npos) << e.what();
  }
  map.valid.clear();
  map.pixel(5)[1] = NAN;
  EXPECT_THROW(project_sh9(map, "nan.exr"), InputError);
  map.pixel(5)[1] = -1;
  EXPECT_THROW(project_sh9(map, "negative.exr"), InputError);
}

TEST(SphericalHarmonics, JsonRoundTripsAndRefusesOtherOrders) {
  Sh9 sh;
  for (int k = 0; k < 9; ++k) sh.coefficients[k] = {k + 0.1, -k / 3.0, 1e-9 * k};
  const std::string text = sh9_to_json(sh, Units::Radiance);
  Units units = Units::Relative;
  const Sh9 back = sh9_from_json(text, "sh.json", &units);
  EXPECT_EQ(units, Units::Radiance);
  for (int k = 0; k < 9; ++k)
    for (int c = 0; c < 3; ++c) EXPECT_EQ(back.coefficients[k][c], sh.coefficients[k][c]);
  std::string order3 = text;
  order3.replace(order3.find("\"order\": 2"), 10, "\"order\": 3");
  EXPECT_THROW(sh9_from_json(order3, "sh.json"), InputError);
}

TEST(SphericalHarmonics, LightListCarriesSh9AndItsContent) {
  LightList list;
  list.sh9 = Sh9{};
  list.sh9->coefficients[4] = {1, 2, 3};
  list.sh9_content = Sh9Content::Map;
  const LightList back = light_list_from_json(to_json(list), "lights.json");
  ASSERT_TRUE(back.sh9.has_value());
  EXPECT_EQ(back.sh9_content, Sh9Content::Map);
  EXPECT_EQ(back.sh9->coefficients[4][2], 3);
  EXPECT_FALSE(light_list_from_json(to_json(LightList{}), "x").sh9.has_value());
}

}  // namespace
}  // namespace lp
