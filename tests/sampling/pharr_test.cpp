// Pharr & Humphreys inverse-CDF sampling: distribution, progressiveness, power split.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "core/envmap.h"
#include "core/error.h"
#include "sampling/sampler.h"

namespace lp {
namespace {

EnvMap constant_latlong(int h, float value) {
  EnvMap m = make_latlong(2 * h, h);
  std::fill(m.rgb.begin(), m.rgb.end(), value);
  return m;
}

std::vector<Light> pharr(const EnvMap& map, int n) {
  auto s = make_sampler(Method::Pharr);
  s->prepare(map);
  return s->place(n);
}

TEST(Pharr, OnAConstantMapLightsAreUniformOverTheSphere) {
  const int n = 1000;
  const auto lights = pharr(constant_latlong(128, 1.0f), n);
  ASSERT_EQ(lights.size(), size_t(n));
  double mx = 0, my = 0, mz = 0, up = 0;
  for (const Light& l : lights) {
    mx += l.direction.x;
    my += l.direction.y;
    mz += l.direction.z;
    up += l.direction.z > 0 ? 1 : 0;
  }
  const double tol = 2 / std::sqrt(double(n));
  EXPECT_NEAR(mx / n, 0.0, tol);
  EXPECT_NEAR(my / n, 0.0, tol);
  EXPECT_NEAR(mz / n, 0.0, tol);
  EXPECT_NEAR(up / n, 0.5, tol);
  // z is uniform on [-1, 1] for a uniform sphere: its variance is 1/3.
  double vz = 0;
  for (const Light& l : lights) vz += l.direction.z * l.direction.z;
  EXPECT_NEAR(vz / n, 1.0 / 3.0, tol);
}

TEST(Pharr, OnAConstantMapEveryLightCarriesAnEqualShareAndSolidAngle) {
  const int n = 64;
  const auto lights = pharr(constant_latlong(64, 2.0f), n);
  // Power of a constant map L over the sphere: 4 pi L per channel.
  for (const Light& l : lights) {
    EXPECT_NEAR(l.rgb[0], 4 * M_PI * 2.0 / n, 1e-5 * 4 * M_PI * 2.0 / n);
    EXPECT_NEAR(l.solid_angle, 4 * M_PI / n, 1e-5);
  }
}

TEST(Pharr, IsProgressiveTheFirstKOfNLightsAreTheKLightAnswer) {
  EnvMap map = constant_latlong(64, 0.1f);
  // A structured map: a bright band and a spot, so the CDFs are not trivial.
  for (int r = 20; r < 30; ++r)
    for (int c = 0; c < map.width; ++c) map.pixel(size_t(r) * map.width + c)[1] = 5.0f;
  map.pixel(size_t(40) * map.width + 17)[0] = 3000.0f;
  auto s = make_sampler(Method::Pharr);
  s->prepare(map);
  const auto all = s->place(300);
  for (int k : {1, 7, 64, 299}) {
    const auto first = s->place(k);
    ASSERT_EQ(first.size(), size_t(k));
    for (int i = 0; i < k; ++i) {
      EXPECT_EQ(first[size_t(i)].id, all[size_t(i)].id);
      EXPECT_LT(angle_between(first[size_t(i)].direction, all[size_t(i)].direction), 1e-12);
    }
  }
}

TEST(Pharr, IdsAreTheHaltonIndicesFromOne) {
  const auto lights = pharr(constant_latlong(32, 1.0f), 50);
  for (size_t i = 0; i < lights.size(); ++i) EXPECT_EQ(lights[i].id, i + 1);
}

TEST(Pharr, TwoPixelsOfPowerRatioThreeToOneGetLightsInThatRatio) {
  EnvMap map = make_latlong(256, 128);
  const size_t a = size_t(30) * 256 + 40, b = size_t(90) * 256 + 200;  // different rows and areas
  const double wa = pixel_solid_angle(map, a), wb = pixel_solid_angle(map, b);
  // Radiances chosen so that the powers (radiance * solid angle) are 3 : 1.
  const float la = 1000.0f, lb = float(1000.0 * wa / wb / 3.0);
  for (int k = 0; k < 3; ++k) {
    map.pixel(a)[k] = la;
    map.pixel(b)[k] = lb;
  }
  const int n = 400;
  const auto lights = pharr(map, n);
  int na = 0, nb = 0;
  for (const Light& l : lights) {
    const auto p = pixel_at(map, l.direction);
    ASSERT_TRUE(p.has_value());
    if (*p == a) ++na;
    else if (*p == b) ++nb;
  }
  EXPECT_EQ(na + nb, n) << "every light lies inside a lit pixel";
  EXPECT_NEAR(double(na) / nb, 3.0, 0.1);
  // Equal power per light: each carries 1/n of the total.
  const double total = la * wa + lb * wb;
  for (const Light& l : lights) EXPECT_NEAR(l.rgb[1], total / n, 1e-5 * total / n);
}

TEST(Pharr, LightsStayInsideTheirPixelAndSpreadOverIt) {
  // One lit pixel: every light lies inside it, and the positions fill the pixel.
  EnvMap map = make_latlong(64, 32);
  const size_t p = size_t(10) * 64 + 5;
  for (int k = 0; k < 3; ++k) map.pixel(p)[k] = 1.0f;
  const auto lights = pharr(map, 200);
  double zmin = 1, zmax = -1, phimin = 10, phimax = -10;
  for (const Light& l : lights) {
    ASSERT_EQ(pixel_at(map, l.direction), p);
    zmin = std::min(zmin, l.direction.z);
    zmax = std::max(zmax, l.direction.z);
    phimin = std::min(phimin, azimuth_of(l.direction));
    phimax = std::max(phimax, azimuth_of(l.direction));
  }
  const double z0 = std::cos(M_PI * 10 / 32), z1 = std::cos(M_PI * 11 / 32);
  EXPECT_GT(zmax - zmin, 0.9 * (z0 - z1));
  EXPECT_GT(phimax - phimin, 0.9 * (2 * M_PI / 64));
}

TEST(Pharr, OnAHemisphereMapEveryLightIsAboveTheHorizonAndPowerIsKept) {
  EnvMap map = make_hemisphere(360, 90);
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    map.pixel(i)[0] = 1.0f + float(i % 7);
    map.pixel(i)[1] = 0.5f;
    map.pixel(i)[2] = float(i % 360) / 100.0f;
  }
  const auto lights = pharr(map, 300);
  ASSERT_EQ(lights.size(), 300u);
  for (const Light& l : lights) EXPECT_GE(l.direction.z, 0.0);
  const auto want = total_power(map), got = total_power(lights);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], want[c], 1e-5 * want[c]);
}

TEST(Pharr, InvalidPixelsGetNoLightsAndNoPower) {
  EnvMap map = constant_latlong(32, 1.0f);
  map.valid.assign(map.pixel_count(), 1);
  for (size_t i = 0; i < map.pixel_count() / 2; ++i) map.valid[i] = 0;  // the upper half is masked
  const auto lights = pharr(map, 100);
  for (const Light& l : lights) EXPECT_LT(l.direction.z, 1e-12);
  const auto want = total_power(map), got = total_power(lights);
  EXPECT_NEAR(got[0], 2 * M_PI, 1e-5 * 2 * M_PI);
  EXPECT_NEAR(got[0], want[0], 1e-5 * want[0]);
}

TEST(Pharr, AHealpixMapIsSampledThroughItsRowGridWithItsPowerKept) {
  EnvMap map = make_healpix(16);
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    const Vec3 d = pixel_direction(map, i);
    map.pixel(i)[0] = float(1 + d.z);
    map.pixel(i)[1] = float(1 + d.x);
    map.pixel(i)[2] = 0.3f;
  }
  const auto lights = pharr(map, 128);
  ASSERT_EQ(lights.size(), 128u);
  const auto want = total_power(map), got = total_power(lights);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], want[c], 1e-5 * want[c]);
}

TEST(Pharr, ABlackMapIsRejected) {
  auto s = make_sampler(Method::Pharr);
  EXPECT_THROW(s->prepare(make_latlong(64, 32)), InputError);
  EXPECT_THROW(s->place(4), InputError) << "no successful prepare yet";
}

}  // namespace
}  // namespace lp
