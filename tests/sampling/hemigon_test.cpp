// Hemigon (Havran's hemisphere inverse transform): the concentric map, the continuous
// warp, equal-power lights over one or both hemispheres, Lloyd-relaxed points, accuracy.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <random>

#include "core/accuracy.h"
#include "core/envmap.h"
#include "core/error.h"
#include "core/image_io.h"
#include "core/resample.h"
#include "sampling/concentric_map.h"
#include "sampling/halton.h"
#include "sampling/hemigon.h"
#include "sampling/sampler.h"

namespace lp {
namespace {

const std::string kGrace = std::string(LIGHTPROBE_SHARED_DATA) + "/probes-probulator-latlong256/grace.hdr";

std::vector<Light> hemigon(const EnvMap& map, int n, SamplerOptions options = {}) {
  auto s = make_sampler(Method::Hemigon, options);
  s->prepare(map);
  return s->place(n);
}

EnvMap constant_hemisphere(int w, int h, float value) {
  EnvMap m = make_hemisphere(w, h);
  std::fill(m.rgb.begin(), m.rgb.end(), value);
  return m;
}

// A strictly positive map with structure in both directions: smooth gradients, a bright
// blob straddling the phi = 0 seam, random per-pixel texture over `decades`.
EnvMap textured_hemisphere(int w, int h, uint32_t seed = 7, float decades = 1.0f) {
  EnvMap m = make_hemisphere(w, h);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> decade(-decades / 2, decades / 2);
  for (size_t i = 0; i < m.pixel_count(); ++i) {
    const Vec3 d = pixel_direction(m, i);
    const double blob = 50 * std::exp(-(std::pow(d.x - 0.7, 2) + d.y * d.y) / 0.02);
    const float base = float((1 + d.z) * (1.0 + blob)) * std::pow(10.0f, decade(rng));
    m.pixel(i)[0] = base;
    m.pixel(i)[1] = 0.8f * base;
    m.pixel(i)[2] = 0.5f * base + 0.01f;
  }
  return m;
}

std::array<double, 3> light_power(const std::vector<Light>& lights) {
  std::array<double, 3> s{0, 0, 0};
  for (const Light& l : lights)
    for (int c = 0; c < 3; ++c) s[c] += l.rgb[c];
  return s;
}

void expect_power_preserved(const std::vector<Light>& lights, const std::array<double, 3>& want) {
  const auto have = light_power(lights);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(have[c], want[c], 1e-5 * want[c]) << "channel " << c;
}

// ---------------------------------------------------------------------------------------

TEST(HemigonConcentricMap, RoundTripsFromTheSquareToTheDiscAndBack) {
  double worst = 0;
  for (int i = 0; i <= 200; ++i)
    for (int j = 0; j <= 200; ++j) {
      const double x = i / 200.0, y = j / 200.0;
      const DiscPoint d = concentric_square_to_disc(x, y);
      ASSERT_LE(d.r, 1.0 + 1e-15);
      ASSERT_GE(d.phi, 0.0);
      ASSERT_LT(d.phi, 2 * M_PI);
      double x2, y2;
      concentric_disc_to_square(d.r, d.phi, &x2, &y2);
      if (d.r > 0) worst = std::max({worst, std::fabs(x2 - x), std::fabs(y2 - y)});
    }
  EXPECT_LT(worst, 1e-12);
}

TEST(HemigonConcentricMap, MapsUniformSquarePointsToUniformDiscPoints) {
  // A fine grid on the square: the fraction within radius rho must be rho^2 and each of
  // eight angular sectors must hold 1/8 (area preservation).
  const int N = 1000;
  const double rhos[] = {0.25, 0.5, 0.7, 0.9};
  double inside[4] = {0, 0, 0, 0}, sector[8] = {0};
  for (int i = 0; i < N; ++i)
    for (int j = 0; j < N; ++j) {
      const DiscPoint d = concentric_square_to_disc((i + 0.5) / N, (j + 0.5) / N);
      for (int k = 0; k < 4; ++k) inside[k] += d.r < rhos[k];
      sector[std::min(7, int(d.phi / (M_PI / 4) + 0.5) % 8)] += 1;  // sectors centred on multiples of 45 deg
    }
  for (int k = 0; k < 4; ++k) EXPECT_NEAR(inside[k] / (double(N) * N), rhos[k] * rhos[k], 2e-3) << rhos[k];
  for (int k = 0; k < 8; ++k) EXPECT_NEAR(sector[k] / (double(N) * N), 1.0 / 8, 2e-3) << k;
}

// ---------------------------------------------------------------------------------------

TEST(Hemigon, OnAConstantHemisphereMapLightsAreUniformInSolidAngle) {
  const int n = 1000;
  const auto lights = hemigon(constant_hemisphere(360, 90, 2.0f), n);
  ASSERT_EQ(lights.size(), size_t(n));
  double mz = 0, mz2 = 0, mx = 0, my = 0;
  for (const Light& l : lights) {
    ASSERT_GE(l.direction.z, 0.0);
    mz += l.direction.z;
    mz2 += l.direction.z * l.direction.z;
    mx += l.direction.x;
    my += l.direction.y;
    // Equal power 2 pi L / n and equal solid angle 2 pi / n.
    EXPECT_NEAR(l.rgb[1], 2 * M_PI * 2.0 / n, 1e-6);
    EXPECT_NEAR(l.solid_angle, 2 * M_PI / n, 1e-6);
  }
  // cos(theta) is uniform on [0, 1] over the hemisphere: mean 1/2, mean square 1/3.
  const double tol = 3 / std::sqrt(double(n));
  EXPECT_NEAR(mz / n, 0.5, tol);
  EXPECT_NEAR(mz2 / n, 1.0 / 3, tol);
  EXPECT_NEAR(mx / n, 0.0, tol);
  EXPECT_NEAR(my / n, 0.0, tol);
}

// Sweeps of the square that cross the concentric map's cut (the phi = 0 meridian,
// y = 1/2, x > 1/2), the disc centre (the pole) and every ring boundary (the diagonals and
// verticals run from the centre to the rim).
struct Sweep {
  double x0, y0, x1, y1;
};
const Sweep kSweeps[] = {{0.8, 0, 0.8, 1}, {0.55, 1, 0.55, 0}, {0, 0, 1, 1}, {1, 0, 0, 1}, {0, 0.7, 1, 0.7}, {0.3, 0, 0.3, 1}};

struct Jumps {
  double raw = 0;       // largest angle between the warps of neighbouring sweep points
  double per_1e6 = 0;   // the largest raw jump per unit step, times 1e-6
  double residual = 0;  // the same after halving every step that jumps > tol, to 1e-12
};

// A continuous warp has residual < tol however steep it is (its jumps shrink with the
// step); a discontinuity keeps its full size however far the step is halved.
Jumps sweep_jumps(const HemigonWarp& warp, int steps, double tol) {
  Jumps out;
  auto dir = [&](double x, double y) { return warp.warp(x, y).direction; };
  std::function<double(double, double, double, double, Vec3, Vec3)> refine =
      [&](double xa, double ya, double xb, double yb, Vec3 da, Vec3 db) {
        const double j = angle_between(da, db);
        if (j < tol || std::hypot(xb - xa, yb - ya) < 1e-12) return j;
        const double xm = 0.5 * (xa + xb), ym = 0.5 * (ya + yb);
        const Vec3 dm = dir(xm, ym);
        return std::max(refine(xa, ya, xm, ym, da, dm), refine(xm, ym, xb, yb, dm, db));
      };
  for (const Sweep& w : kSweeps) {
    double xa = w.x0, ya = w.y0;
    Vec3 da = dir(xa, ya);
    for (int i = 1; i <= steps; ++i) {
      const double t = double(i) / steps;
      const double xb = w.x0 + (w.x1 - w.x0) * t, yb = w.y0 + (w.y1 - w.y0) * t;
      const Vec3 db = dir(xb, yb);
      const double j = angle_between(da, db);
      out.raw = std::max(out.raw, j);
      out.per_1e6 = std::max(out.per_1e6, 1e-6 * j / std::hypot(xb - xa, yb - ya));
      if (j >= tol) out.residual = std::max(out.residual, refine(xa, ya, xb, yb, da, db));
      xa = xb;
      ya = yb;
      da = db;
    }
  }
  return out;
}

TEST(Hemigon, WarpIsContinuousAcrossTheSeamThePoleAndBetweenRings) {
  // One decade of per-pixel texture and a 50x blob on the seam.
  const EnvMap map = textured_hemisphere(360, 90);
  HemigonWarp warp;
  warp.build(map);
  const Jumps j = sweep_jumps(warp, 250000, 1e-3);  // steps of 4e-6 (diagonals 5.7e-6)
  // A step of 1e-6 moves the direction by less than 1e-3 rad ...
  EXPECT_LT(j.per_1e6, 1e-3);
  // ... and no jump survives refinement: continuous across the cut, the pole and rings.
  EXPECT_LT(j.residual, 1e-3);
  // Points just either side of the cut land on the same meridian.
  for (double x : {0.51, 0.6, 0.8, 0.99}) {
    const Vec3 below = warp.warp(x, 0.5 - 1e-9).direction, above = warp.warp(x, 0.5 + 1e-9).direction;
    EXPECT_LT(angle_between(below, above), 1e-5) << x;
  }
}

TEST(Hemigon, TheContinuityCheckSeesTheUnavoidableJumpAcrossABlackBand) {
  // The check above is not blind: a black ring band (theta 40..50 deg) separates two lit
  // regions, so points must jump across it: by at least its 10 deg width (more where the
  // rings either side send the same xi2 to different azimuths).
  EnvMap map = textured_hemisphere(360, 90);
  for (int v = 40; v < 50; ++v)
    for (int u = 0; u < 360; ++u) std::fill_n(map.pixel(size_t(v) * 360 + size_t(u)), 3, 0.0f);
  HemigonWarp warp;
  warp.build(map);
  const Jumps j = sweep_jumps(warp, 100000, 1e-3);
  EXPECT_GT(j.residual, 0.9 * (10 * M_PI / 180));
}

TEST(Hemigon, ExactlyNLightsWithProgressiveHaltonIdsAndPreservedPower) {
  const EnvMap map = textured_hemisphere(360, 90);
  auto sampler = make_sampler(Method::Hemigon);
  sampler->prepare(map);
  const auto small = sampler->place(37);
  const auto big = sampler->place(300);
  ASSERT_EQ(small.size(), 37u);
  ASSERT_EQ(big.size(), 300u);
  for (size_t i = 0; i < big.size(); ++i) EXPECT_EQ(big[i].id, i + 1);
  // The first k lights of an n-light answer are the k-light answer, power rescaled.
  for (size_t i = 0; i < small.size(); ++i) {
    EXPECT_EQ(small[i].id, big[i].id);
    EXPECT_LT(angle_between(small[i].direction, big[i].direction), 1e-12);
    // Equal power per light; the per-channel power match is one factor per channel.
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(small[i].rgb[c] / big[i].rgb[c], small[0].rgb[c] / big[0].rgb[c], 1e-9) << i;
  }
  EXPECT_NEAR(small[0].luminance() / big[0].luminance(), 300.0 / 37, 1e-3 * 300 / 37);
  expect_power_preserved(small, total_power(map));
  expect_power_preserved(big, total_power(map));
  // Equal luminance per light, up to the per-channel power match (colour noise).
  for (const Light& l : big) EXPECT_NEAR(l.luminance(), big[0].luminance(), 1e-3 * big[0].luminance());
}

TEST(Hemigon, AOnePixelSunGetsEveryLightWithinOnePixelOfIt) {
  // Rows: pole, middle, horizon; columns: next to the phi = 0 seam and elsewhere.
  const int W = 360, H = 90;
  const double pixel_diagonal = std::hypot(M_PI / 2 / H, 2 * M_PI / W);
  for (auto [u, v] : {std::pair{0, 0}, std::pair{359, 45}, std::pair{123, 89}, std::pair{200, 30}}) {
    EnvMap map = make_hemisphere(W, H);
    const size_t sun = size_t(v) * W + size_t(u);
    map.pixel(sun)[0] = 1000.0f;
    map.pixel(sun)[1] = 900.0f;
    map.pixel(sun)[2] = 700.0f;
    const auto lights = hemigon(map, 256);
    ASSERT_EQ(lights.size(), 256u);
    double worst = 0;
    for (const Light& l : lights) worst = std::max(worst, angle_between(l.direction, pixel_direction(map, sun)));
    EXPECT_LE(worst, pixel_diagonal) << "sun at pixel (" << u << ", " << v << ")";
    expect_power_preserved(lights, total_power(map));
    // The sun's colour survives.
    EXPECT_NEAR(lights[0].rgb[2] / lights[0].rgb[0], 0.7, 1e-6);
  }
}

TEST(Hemigon, InvalidPixelsGetNoLights) {
  EnvMap map = constant_hemisphere(360, 90, 1.0f);
  map.valid.assign(map.pixel_count(), 1);
  for (size_t i = 0; i < map.pixel_count(); ++i)
    if (i % 360 >= 180) {  // phi in [pi, 2 pi): invalid, and very bright
      map.valid[i] = 0;
      map.pixel(i)[0] = map.pixel(i)[1] = map.pixel(i)[2] = 1e6f;
    }
  const auto lights = hemigon(map, 200);
  for (const Light& l : lights) EXPECT_GE(l.direction.y, -1e-9);
  expect_power_preserved(lights, total_power(map));
}

TEST(Hemigon, PreparingAgainReusesTheSamplerForTheNextFrame) {
  auto sampler = make_sampler(Method::Hemigon);
  const EnvMap first = textured_hemisphere(360, 90, 1);  // place() reads it (sampler.h)
  sampler->prepare(first);
  (void)sampler->place(100);
  const EnvMap second = textured_hemisphere(200, 50, 2);
  sampler->prepare(second);
  const auto again = sampler->place(100);
  const auto fresh = hemigon(second, 100);
  for (size_t i = 0; i < fresh.size(); ++i) {
    EXPECT_EQ(again[i].direction.x, fresh[i].direction.x);
    EXPECT_EQ(again[i].rgb[1], fresh[i].rgb[1]);
  }
}

TEST(Hemigon, RejectsBlackMapsAndNonPositiveCounts) {
  EXPECT_THROW(hemigon(make_hemisphere(360, 90), 10), InputError);
  EXPECT_THROW(hemigon(constant_hemisphere(36, 9, 1.0f), 0), InputError);
  // A latlong map lit only from below has nothing to sample with upper_only.
  EnvMap below = make_latlong(128, 64);
  for (size_t i = 0; i < below.pixel_count(); ++i)
    if (pixel_direction(below, i).z < -0.1) below.pixel(i)[1] = 1.0f;
  SamplerOptions upper;
  upper.upper_only = true;
  EXPECT_THROW(hemigon(below, 10, upper), InputError);
  EXPECT_EQ(hemigon(below, 10).size(), 10u);  // the full sphere has light
}

// ---------------------------------------------------------------------------------------
// Full sphere: other layouts are resampled to an upper and a lower hemisphere map.

EnvMap two_level_latlong(float up, float down) {
  EnvMap m = make_latlong(256, 128);
  for (size_t i = 0; i < m.pixel_count(); ++i) {
    const float v = pixel_direction(m, i).z > 0 ? up : down;
    m.pixel(i)[0] = v;
    m.pixel(i)[1] = v;
    m.pixel(i)[2] = v;
  }
  return m;
}

TEST(Hemigon, FullSphereSharesTheLightsBetweenHemispheresByPower) {
  const int n = 1000;
  const EnvMap map = two_level_latlong(1.0f, 3.0f);  // 3x the power below
  const auto lights = hemigon(map, n);
  ASSERT_EQ(lights.size(), size_t(n));
  int below = 0;
  double mz_below = 0;
  for (const Light& l : lights)
    if (l.direction.z < 0) {
      ++below;
      mz_below += l.direction.z;
    }
  EXPECT_NEAR(below / double(n), 0.75, 0.01);
  // Uniform within the lower hemisphere too: mean z = -1/2.
  EXPECT_NEAR(mz_below / below, -0.5, 3 / std::sqrt(double(below)));
  expect_power_preserved(lights, total_power(map));
  for (size_t i = 0; i < lights.size(); ++i) EXPECT_EQ(lights[i].id, i + 1);
}

TEST(Hemigon, UpperOnlyPutsEveryLightAboveTheHorizonWithTheUpperPower) {
  const EnvMap map = two_level_latlong(1.0f, 3.0f);
  SamplerOptions options;
  options.upper_only = true;
  const auto lights = hemigon(map, 500, options);
  ASSERT_EQ(lights.size(), 500u);
  for (const Light& l : lights) EXPECT_GE(l.direction.z, 0.0);
  // Upper hemisphere power of a constant 1 is 2 pi per channel.
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(light_power(lights)[c], 2 * M_PI, 1e-4 * 2 * M_PI);
}

TEST(Hemigon, FindsASunInTheLowerHemisphereOfALatLongMap) {
  EnvMap map = make_latlong(256, 128);
  std::fill(map.rgb.begin(), map.rgb.end(), 1e-3f);
  const Vec3 sun = normalize(Vec3{0.3, -0.5, -0.6});
  const size_t p = *pixel_at(map, sun);
  map.pixel(p)[0] = map.pixel(p)[1] = map.pixel(p)[2] = 1e5f;
  const auto lights = hemigon(map, 200);
  int near_sun = 0;
  for (const Light& l : lights) near_sun += angle_between(l.direction, pixel_direction(map, p)) < 0.05;
  // The sun carries ~ 99 % of the power; its lights must sit on it, in the world frame.
  EXPECT_GE(near_sun, 190);
  expect_power_preserved(lights, total_power(map));
}

// ---------------------------------------------------------------------------------------

TEST(Hemigon, LloydRelaxedPointsStaySpreadAndAreCachedPerCount) {
  const int n = 128;
  const auto& relaxed = lloyd_relaxed_halton(n);
  ASSERT_EQ(relaxed.size(), size_t(n));
  EXPECT_EQ(&relaxed, &lloyd_relaxed_halton(n));  // cached
  auto min_distance = [](const std::vector<std::array<double, 2>>& p) {
    double best = 1e9;
    for (size_t i = 0; i < p.size(); ++i)
      for (size_t j = i + 1; j < p.size(); ++j)
        best = std::min(best, std::hypot(p[i][0] - p[j][0], p[i][1] - p[j][1]));
    return best;
  };
  std::vector<std::array<double, 2>> halton(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) halton2(uint64_t(i) + 1, &halton[size_t(i)][0], &halton[size_t(i)][1]);
  for (const auto& q : relaxed) {
    EXPECT_GE(q[0], 0.0);
    EXPECT_LE(q[0], 1.0);
    EXPECT_GE(q[1], 0.0);
    EXPECT_LE(q[1], 1.0);
  }
  // Relaxation pushes close pairs apart: a blue-noise-like minimum spacing, for a
  // hexagonal packing about 1.07 / sqrt(n).
  EXPECT_GT(min_distance(relaxed), 1.5 * min_distance(halton));
  EXPECT_GT(min_distance(relaxed), 0.6 / std::sqrt(double(n)));

  SamplerOptions options;
  options.lloyd_relaxed = true;
  const EnvMap map = textured_hemisphere(360, 90);
  const auto lights = hemigon(map, n, options);
  ASSERT_EQ(lights.size(), size_t(n));
  for (size_t i = 0; i < lights.size(); ++i) EXPECT_EQ(lights[i].id, i + 1);
  expect_power_preserved(lights, total_power(map));
  // On a constant map the relaxed points are uniform in solid angle too.
  double mz = 0;
  for (const Light& l : hemigon(constant_hemisphere(360, 90, 1.0f), n, options)) mz += l.direction.z;
  EXPECT_NEAR(mz / n, 0.5, 1 / std::sqrt(double(n)));
}

// ---------------------------------------------------------------------------------------
// Real data: a Debevec light probe (latlong 512 x 256, strong small windows).

TEST(Hemigon, OnGraceDiffuseErrorIsBelowOneAndAHalfPercentAt1024Lights) {
  if (!std::filesystem::exists(kGrace)) GTEST_SKIP() << kGrace << " is missing";
  const EnvMap map = read_envmap(kGrace);
  AccuracyOptions ao;
  ao.shadowed = false;
  const AccuracyReference ref = make_accuracy_reference(map, ao);
  auto sampler = make_sampler(Method::Hemigon);
  sampler->prepare(map);
  const auto l64 = sampler->place(64);
  const auto l1024 = sampler->place(1024);
  const double e64 = light_error(ref, l64).diffuse, e1024 = light_error(ref, l1024).diffuse;
  EXPECT_LT(e1024, 0.015);
  EXPECT_LE(e1024, 0.5 * e64);
  expect_power_preserved(l1024, total_power(map));
  RecordProperty("diffuse_error_64", std::to_string(e64));
  RecordProperty("diffuse_error_1024", std::to_string(e1024));
}

TEST(Hemigon, OnGraceTheWarpIsContinuousWhereverTheMapIsNotBlack) {
  if (!std::filesystem::exists(kGrace)) GTEST_SKIP() << kGrace << " is missing";
  const EnvMap map = read_envmap(kGrace);
  // The upper hemisphere as the sampler builds it from a 512 x 256 latlong: 512 x 128.
  EnvMap polar = resample(map, Layout::Hemisphere, 512, 128);
  // Grace has exactly-black RGBE pixels; across a black gap every inverse transform must
  // jump (f = 0 there). Lifting them by 1e-6 of the mean radiance changes nothing else.
  const double mean = total_luminance_power(polar) / (2 * M_PI);
  int black = 0;
  for (size_t i = 0; i < polar.pixel_count(); ++i) {
    float* p = polar.pixel(i);
    if (luminance(p[0], p[1], p[2]) == 0) {
      ++black;
      p[0] = p[1] = p[2] = float(1e-6 * mean);
    }
  }
  EXPECT_GT(black, 0);
  HemigonWarp warp;
  warp.build(polar);
  const Jumps j = sweep_jumps(warp, 100000, 1e-3);
  // Steps of 1e-5 can jump far where a dark pixel sits in a ring lit by a window (the
  // inverse CDF is steep there: luminance ratios reach ~1e6), but every jump shrinks
  // below 1e-3 rad when the step is refined: no discontinuity anywhere on the sweeps.
  EXPECT_LT(j.residual, 1e-3);
  RecordProperty("max_jump_at_step_1e-5_rad", std::to_string(j.raw));
  RecordProperty("max_jump_per_1e-6_rad", std::to_string(j.per_1e6));
}

// The sampler builds the two halves of a latlong map whose grid is the hemisphere's (same
// width, a power of two; half the height) from the map's rows instead of resampling it. The
// upper half is the resample's copy (as numbers: it writes -0 as +0). The lower half
// (Rx(180)) differs only where the resample leaked ~1e-16 of a neighbour row into a pixel
// (its row boundaries compare -cos(pi - x) with cos(x), unequal in the last bit): warped
// points agree to 1e-10 rad (a point in a black pixel that the resample made 1e-16 bright
// may sit elsewhere in it) and their radiance to 1e-10 of the larger of itself and the mean
// radiance (the map itself is float: 6e-8).
TEST(HemigonWarp, RowsOfALatlongHalfWarpLikeTheResampledHalf) {
  const std::string night = std::string(LIGHTPROBE_SHARED_DATA) + "/probes-blender-studiolights/night.exr";
  if (!std::filesystem::exists(night)) GTEST_SKIP() << night << " is missing";
  const EnvMap map = read_envmap(night);
  ASSERT_EQ(map.width, 1024);
  const int w = map.width, h = map.height / 2;
  ResampleOptions flip;
  flip.world_from_source = Mat3{{1, 0, 0, 0, -1, 0, 0, 0, -1}};
  for (int half = 0; half < 2; ++half) {
    HemigonWarp resampled, rows;
    resampled.build(resample(map, Layout::Hemisphere, w, h, half ? flip : ResampleOptions{}));
    std::vector<HemigonWarp::Row> r(static_cast<size_t>(h));
    for (int v = 0; v < h; ++v) {
      const size_t row = half ? size_t(map.height - 1 - v) : size_t(v);
      r[size_t(v)] = {map.rgb.data() + 3 * row * size_t(w), nullptr, half == 1};
    }
    rows.build(w, h, r.data());
    if (half == 0) {
      EXPECT_EQ(rows.power(), resampled.power());
      EXPECT_EQ(rows.rgb_power(), resampled.rgb_power());
    } else {
      EXPECT_NEAR(rows.power(), resampled.power(), 1e-14 * resampled.power());
    }
    double worst_direction = 0, worst_rgb = 0;
    const double mean_radiance = resampled.power() / (2 * M_PI);
    for (int i = 0; i < 4096; ++i) {
      double x, y;
      halton2(uint64_t(i) + 1, &x, &y);
      const auto a = rows.warp(x, y), b = resampled.warp(x, y);
      worst_direction = std::max(worst_direction, length(a.direction - b.direction));
      for (int c = 0; c < 3; ++c)
        worst_rgb = std::max(worst_rgb, std::abs(a.rgb[c] - b.rgb[c]) / std::max(mean_radiance, std::abs(b.rgb[c])));
      if (half == 0) {
        ASSERT_EQ(a.direction.x, b.direction.x) << i;
        ASSERT_EQ(a.direction.z, b.direction.z) << i;
        ASSERT_EQ(a.rgb, b.rgb) << i;
      }
    }
    EXPECT_LT(worst_direction, 1e-10) << "half " << half;
    EXPECT_LT(worst_rgb, 1e-10) << "half " << half;
    if (half == 1) {
      EXPECT_GT(worst_direction, 0.0) << "the lower half no longer differs: make it bit-exact above";
    }
  }
}

// Rows warped where they are (`borrow`, what the sampler does) give the copy's warp bit for
// bit: rows forwards and reversed, with and without a mask (holes and a masked band), with and
// without the channel sums; the same map's rows, so any difference is the borrowing's. The
// masked pixels are 1e6 bright: a lookup that missed the mask would show them (a sample's
// colour blends two rings' pixels, so holes next to valid pixels are looked up).
TEST(HemigonWarp, BorrowedRowsWarpLikeCopiedOnes) {
  EnvMap map = textured_hemisphere(360, 90, 5, 3.0f);
  std::vector<uint8_t> valid(map.pixel_count(), 1);
  for (size_t i = 0; i < valid.size(); i += 5) valid[i] = 0;
  for (size_t i = 360 * 20; i < 360 * 23; ++i) valid[i] = 0;
  for (size_t i = 0; i < valid.size(); ++i)
    if (!valid[i]) map.rgb[3 * i] = map.rgb[3 * i + 1] = map.rgb[3 * i + 2] = 1e6f;
  for (int variant = 0; variant < 8; ++variant) {
    const bool reversed = variant & 1, masked = variant & 2, rgb_power = variant & 4;
    std::vector<HemigonWarp::Row> rows(90);
    for (size_t v = 0; v < rows.size(); ++v)
      rows[v] = {map.rgb.data() + 3 * 360 * v, masked ? valid.data() + 360 * v : nullptr, reversed};
    HemigonWarp copied, borrowed;
    copied.build(360, 90, rows.data(), rgb_power, false);
    borrowed.build(360, 90, rows.data(), rgb_power, true);
    const std::string what = "variant " + std::to_string(variant);
    EXPECT_EQ(borrowed.power(), copied.power()) << what;
    EXPECT_EQ(borrowed.rgb_power(), copied.rgb_power()) << what;
    if (rgb_power) {
      EXPECT_GT(copied.rgb_power()[1], 0.0) << what;
    }
    double brightest = 0;
    for (int i = 0; i < 4096; ++i) {
      double x, y;
      halton2(uint64_t(i) + 1, &x, &y);
      const auto a = borrowed.warp(x, y), b = copied.warp(x, y);
      ASSERT_EQ(a.direction.x, b.direction.x) << what << ", point " << i;
      ASSERT_EQ(a.direction.y, b.direction.y) << what << ", point " << i;
      ASSERT_EQ(a.rgb, b.rgb) << what << ", point " << i;
      ASSERT_EQ(a.luminance, b.luminance) << what << ", point " << i;
      brightest = std::max(brightest, a.rgb[1]);
    }
    // Unmasked, the warp does reach the bright pixels: the masked case looked them up too.
    if (!masked) {
      EXPECT_GT(brightest, 1e5) << what;
    } else {
      EXPECT_LT(brightest, 1e4) << what;  // the map's own pixels reach ~2e3
    }
  }
}

}  // namespace
}  // namespace lp
