#include "core/resample.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "core/envmap.h"
#include "core/error.h"

namespace lp {
namespace {

// A smooth, positive, channel-dependent radiance with no symmetry to hide errors behind.
double smooth_radiance(Vec3 d, int c) {
  return 1.0 + 0.5 * std::sin(3 * d.x + 1 + c) * std::cos(2 * d.y - 0.5 * c) + 0.3 * d.z * d.z + 0.2 * c * d.x;
}

EnvMap smooth_map(EnvMap map) {
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    const Vec3 d = pixel_direction(map, i);
    for (int c = 0; c < 3; ++c) map.pixel(i)[c] = float(smooth_radiance(d, c));
  }
  return map;
}

EnvMap constant_map(EnvMap map, float value) {
  std::fill(map.rgb.begin(), map.rgb.end(), value);
  return map;
}

struct Size {
  Layout layout;
  int width, height;  // healpix: width is nside
};

EnvMap make(Size s) { return make_envmap(s.layout, s.width, s.height); }
std::string name(Size s) { return describe_size(make(s)); }

// Per-channel power of the part of a full-sphere map above the horizon (z > 0), with
// the pixel-constant radiance of the map. Latlong maps with an even number of rows
// split exactly at the horizon; HEALPix pixels centred on the equator are symmetric
// about it, so exactly half of each lies above.
std::array<double, 3> upper_half_power(const EnvMap& map) {
  std::array<double, 3> sum{0, 0, 0};
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    const double z = pixel_direction(map, i).z;
    const double f = z > 1e-12 ? 1.0 : z < -1e-12 ? 0.0 : 0.5;
    for (int c = 0; c < 3; ++c) sum[c] += f * pixel_solid_angle(map, i) * map.pixel(i)[c];
  }
  return sum;
}

void expect_power_near(const std::array<double, 3>& got, const std::array<double, 3>& want, double rel,
                       const std::string& what) {
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], want[c], rel * want[c]) << what << " channel " << c;
}

TEST(Resample, EveryPairOfLayoutsKeepsTheTotalPowerOfASmoothMap) {
  const std::vector<Size> sphere = {{Layout::LatLong, 256, 128}, {Layout::Healpix, 64, 0}};
  const Size hemi{Layout::Hemisphere, 360, 90};
  for (Size from : sphere) {
    const EnvMap src = smooth_map(make(from));
    for (Size to : sphere) {
      const EnvMap dst = resample(src, to.layout, to.width, to.height);
      EXPECT_TRUE(dst.valid.empty()) << name(from) << " -> " << name(to);
      expect_power_near(total_power(dst), total_power(src), 1e-4, name(from) + " -> " + name(to));
    }
    // A hemisphere keeps the upper half, and all of its power.
    const EnvMap up = resample(src, hemi.layout, hemi.width, hemi.height);
    expect_power_near(total_power(up), upper_half_power(src), 1e-4, name(from) + " -> " + name(hemi));
  }
  const EnvMap src = smooth_map(make(hemi));
  for (Size to : sphere) {
    const EnvMap dst = resample(src, to.layout, to.width, to.height);
    expect_power_near(total_power(dst), total_power(src), 1e-4, name(hemi) + " -> " + name(to));
  }
}

// Largest angle from a pixel's centre to its boundary ("half a pixel"): the corners for
// latlong/hemisphere; for healpix the farthest of its NESTED children at 128 times the
// resolution, plus one child's size.
double half_pixel(const EnvMap& map, size_t p) {
  const Vec3 c = pixel_direction(map, p);
  double r = 0;
  if (map.layout == Layout::Healpix) {
    EnvMap fine;  // geometry only: no pixels allocated
    fine.layout = Layout::Healpix;
    fine.nside = map.nside * 128;
    fine.width = 12 * fine.nside * fine.nside;
    fine.height = 1;
    const size_t n = 128 * 128;
    for (size_t i = p * n; i < (p + 1) * n; ++i) r = std::max(r, angle_between(c, pixel_direction(fine, i)));
    return r + std::sqrt(pixel_solid_angle(fine, 0));
  }
  const double span = map.layout == Layout::Hemisphere ? M_PI / 2 : M_PI;
  const size_t u = p % size_t(map.width), v = p / size_t(map.width);
  for (int du = 0; du < 2; ++du)
    for (int dv = 0; dv < 2; ++dv) {
      const Vec3 corner =
          direction_from_angles(span * double(v + dv) / map.height, 2 * M_PI * double(u + du) / map.width);
      r = std::max(r, angle_between(c, corner));
    }
  return r;
}

// Power-weighted (luminance) mean direction of a map.
Vec3 mean_direction(const EnvMap& map) {
  Vec3 sum{};
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    if (!map.is_valid(i)) continue;
    const float* l = map.pixel(i);
    sum = sum + (pixel_solid_angle(map, i) * luminance(l[0], l[1], l[2])) * pixel_direction(map, i);
  }
  return normalize(sum);
}

EnvMap one_pixel_sun(int width, int height, int u, int v) {
  EnvMap map = make_latlong(width, height);
  float* p = map.pixel(size_t(v) * width + u);
  p[0] = 5e4f;
  p[1] = 4e4f;
  p[2] = 3e4f;
  return map;
}

// Direction of latlong pixel (u, v) by the CONVENTIONS formula.
Vec3 latlong_centre(int width, int height, int u, int v) {
  return direction_from_angles(M_PI * (v + 0.5) / height, 2 * M_PI * (u + 0.5) / width);
}

TEST(Resample, AOnePixelSunKeepsItsPowerAndDirectionDownAndUpInResolution) {
  const int w = 1024, h = 512;
  // Equator, mid-latitudes, next to the pole, on the pole row, at the phi = 0 seam (both sides).
  const std::vector<std::array<int, 2>> suns = {{300, 256}, {517, 100}, {77, 1}, {700, 0}, {0, 200}, {1023, 333}};
  const std::vector<Size> targets = {{Layout::LatLong, 128, 64}, {Layout::Healpix, 32, 0}, {Layout::LatLong, 2048, 1024}};
  for (const auto& [u, v] : suns) {
    const EnvMap src = one_pixel_sun(w, h, u, v);
    const Vec3 truth = latlong_centre(w, h, u, v);
    const double src_half = half_pixel(src, size_t(v) * w + u);
    for (Size to : targets) {
      const EnvMap dst = resample(src, to.layout, to.width, to.height);
      const std::string what = "sun (" + std::to_string(u) + ", " + std::to_string(v) + ") -> " + name(to);
      expect_power_near(total_power(dst), total_power(src), 1e-4, what);
      const double dst_half = half_pixel(dst, *pixel_at(dst, truth));
      const double err = angle_between(mean_direction(dst), truth);
      // Going down, the sun lands in (or is shared among) destination pixels around its
      // own; going up, its power is spread over the finer pixels inside it.
      EXPECT_LE(err, std::max(dst_half, src_half)) << what;
      if (dst_half < src_half) {
        EXPECT_LE(err, dst_half) << what;
      }
    }
  }
}

TEST(Resample, ALatlongToHealpixRoundTripKeepsPowerAndTheSunsDirection) {
  const int w = 512, h = 256;
  for (const auto& [u, v] : std::vector<std::array<int, 2>>{{100, 128}, {0, 40}, {333, 3}, {511, 250}}) {
    const EnvMap src = one_pixel_sun(w, h, u, v);
    const EnvMap hp = resample(src, Layout::Healpix, 128, 0);
    const EnvMap back = resample(hp, Layout::LatLong, w, h);
    const std::string what = "sun (" + std::to_string(u) + ", " + std::to_string(v) + ")";
    expect_power_near(total_power(hp), total_power(src), 1e-4, what + " in healpix");
    expect_power_near(total_power(back), total_power(src), 1e-4, what + " back in latlong");
    const Vec3 truth = latlong_centre(w, h, u, v);
    const double err = angle_between(mean_direction(back), truth);
    EXPECT_LE(err, half_pixel(src, size_t(v) * w + u)) << what;
  }
}

TEST(Resample, RotatingByNinetyDegreesOfYawMovesASunAtPhiZeroToPhiNinety) {
  const int w = 512, h = 256, u = 0, v = 100;  // phi = half a pixel, just past the seam
  const EnvMap src = one_pixel_sun(w, h, u, v);
  const Mat3 yaw90 = rotation_from_yaw_pitch_roll_deg(90, 0, 0);
  const EnvMap dst = rotate(src, yaw90);
  ASSERT_EQ(dst.layout, Layout::LatLong);
  ASSERT_EQ(dst.width, w);
  expect_power_near(total_power(dst), total_power(src), 1e-4, "yaw 90");
  const Vec3 got = mean_direction(dst);
  const Vec3 want = latlong_centre(w, h, u + w / 4, v);  // phi + 90 degrees, same theta
  EXPECT_NEAR(azimuth_of(got), M_PI / 2 + M_PI / w, 1e-9);
  EXPECT_LE(angle_between(got, want), half_pixel(dst, size_t(v) * w + u + w / 4));
  // 90 degrees is a whole number of columns: the sun is moved, not blurred.
  EXPECT_FLOAT_EQ(dst.pixel(size_t(v) * w + u + w / 4)[0], src.pixel(size_t(v) * w + u)[0]);
}

// A matrix close to a rotation (typed to four decimals, or perturbed) goes to the rotation
// nearest to it: orthonormal to rounding, and the exact one when the input is a scaled one.
TEST(Rotation, TheNearestRotationOfAMatrixTypedToFourDecimalsIsExact) {
  const Mat3 typed{{0.7071, -0.7071, 0, 0.7071, 0.7071, 0, 0, 0, 1}};
  EXPECT_FALSE(is_rotation(typed));
  const Mat3 r = nearest_rotation(typed);
  EXPECT_TRUE(is_rotation(r, 1e-14));
  const Mat3 yaw45 = rotation_from_yaw_pitch_roll_deg(45, 0, 0);
  for (size_t k = 0; k < 9; ++k) EXPECT_NEAR(r.m[k], yaw45.m[k], 1e-15) << k;
  // A rotation perturbed by 1e-5 per element: the polar factor moves it by about as much,
  // and a rotation is its own nearest.
  const Mat3 q = rotation_from_yaw_pitch_roll_deg(31, -12, 77);
  Mat3 p = q;
  for (size_t k = 0; k < 9; ++k) p.m[k] += 1e-5 * double(int(k % 3) - 1);
  const Mat3 back = nearest_rotation(p);
  EXPECT_TRUE(is_rotation(back, 1e-14));
  for (size_t k = 0; k < 9; ++k) EXPECT_NEAR(back.m[k], q.m[k], 3e-5) << k;
  const Mat3 same = nearest_rotation(q);
  for (size_t k = 0; k < 9; ++k) EXPECT_NEAR(same.m[k], q.m[k], 1e-15) << k;
}

// yaw_pitch_roll_deg undoes rotation_from_yaw_pitch_roll_deg, also at the gimbal lock
// (pitch +-90, where only the combination is defined: the matrix comes back).
TEST(Rotation, YawPitchRollComeBackFromTheirMatrix) {
  for (const std::array<double, 3>& a : std::vector<std::array<double, 3>>{
           {30, 10, -5}, {-170, -89, 179}, {0, 0, 0}, {90, 0, 0}, {135, 45, -120}, {-45, 60, 30}}) {
    const auto b = yaw_pitch_roll_deg(rotation_from_yaw_pitch_roll_deg(a[0], a[1], a[2]));
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(b[size_t(k)], a[size_t(k)], 1e-9) << a[0] << " " << a[1] << " " << a[2];
  }
  for (double pitch : {90.0, -90.0}) {
    const Mat3 r = rotation_from_yaw_pitch_roll_deg(40, pitch, 25);
    const auto b = yaw_pitch_roll_deg(r);
    EXPECT_NEAR(b[1], pitch, 1e-6);
    EXPECT_EQ(b[2], 0.0);
    const Mat3 back = rotation_from_yaw_pitch_roll_deg(b[0], b[1], b[2]);
    for (size_t k = 0; k < 9; ++k) EXPECT_NEAR(back.m[k], r.m[k], 1e-9) << pitch << " " << k;
  }
}

// A map unwrapped with a probe rotation (EnvMap::world_from_probe) and turned again keeps
// the record of the whole turn; one without a record gains none.
TEST(Resample, TurningAMapTurnsItsRecordedProbeRotationWithIt) {
  EnvMap src = one_pixel_sun(64, 32, 5, 10);
  const Mat3 yaw90 = rotation_from_yaw_pitch_roll_deg(90, 0, 0);
  EXPECT_FALSE(rotate(src, yaw90).world_from_probe.has_value());
  const Mat3 probe = rotation_from_yaw_pitch_roll_deg(12, -30, 7);
  src.world_from_probe = probe;
  const EnvMap dst = rotate(src, yaw90);
  ASSERT_TRUE(dst.world_from_probe.has_value());
  const Mat3 want = yaw90 * probe;
  for (size_t k = 0; k < 9; ++k) EXPECT_NEAR(dst.world_from_probe->m[k], want.m[k], 1e-15) << k;
  EXPECT_GT(std::abs(dst.world_from_probe->m[0] - probe.m[0]), 0.1);  // it did turn
}

TEST(Resample, AnArbitraryRotationKeepsThePowerOfASmoothMap) {
  const Mat3 r = rotation_from_yaw_pitch_roll_deg(33, -20, 12);
  for (const EnvMap& src : {smooth_map(make_latlong(256, 128)), smooth_map(make_healpix(64))}) {
    const EnvMap dst = rotate(src, r);
    expect_power_near(total_power(dst), total_power(src), 1e-4, "rotated " + describe_size(src));
  }
}

TEST(Resample, ARotatedSunMovesWhereTheRotationSendsIt) {
  // A sun at the zenith pitched by 90 degrees about +Y goes to +X.
  const EnvMap src = one_pixel_sun(512, 256, 40, 0);
  const Mat3 pitch90 = rotation_from_yaw_pitch_roll_deg(0, 90, 0);
  const EnvMap dst = rotate(src, pitch90);
  expect_power_near(total_power(dst), total_power(src), 1e-4, "pitch 90");
  const Vec3 want = pitch90 * latlong_centre(512, 256, 40, 0);
  EXPECT_LE(angle_between(mean_direction(dst), want), half_pixel(dst, *pixel_at(dst, want)));
}

void expect_constant(const EnvMap& map, float value, const std::string& what) {
  size_t valid = 0;
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    if (!map.is_valid(i)) continue;
    ++valid;
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(map.pixel(i)[c], value, 1e-5 * value) << what << " pixel " << i;
  }
  EXPECT_GT(valid, 0u) << what;
}

TEST(Resample, AConstantMapStaysConstantWhereTheGridsNest) {
  const float l = 3.5f;
  const EnvMap ll = constant_map(make_latlong(256, 128), l);
  expect_constant(rotate(ll, rotation_from_yaw_pitch_roll_deg(90, 0, 0)), l, "latlong yaw 90");
  expect_constant(rotate(ll, rotation_from_yaw_pitch_roll_deg(-45, 0, 0)), l, "latlong yaw -45");
  expect_constant(resample(ll, Layout::LatLong, 256, 128), l, "latlong identity");
  const EnvMap hp = constant_map(make_healpix(64), l);
  expect_constant(resample(hp, Layout::Healpix, 16, 0), l, "healpix 64 -> 16");
  expect_constant(resample(hp, Layout::Healpix, 256, 0), l, "healpix 64 -> 256");
  expect_constant(rotate(hp, Mat3{}), l, "healpix identity");
  const EnvMap hemi = constant_map(make_hemisphere(360, 90), l);
  expect_constant(rotate(hemi, rotation_from_yaw_pitch_roll_deg(180, 0, 0)), l, "hemisphere yaw 180");
}

TEST(Resample, AConstantMapStaysNearlyConstantBetweenLayouts) {
  // Not exact where the grids do not nest (sampling noise in W_s), but balanced: the
  // mean is exact (power) and the spread is small.
  const float l = 2.0f;
  const std::vector<Size> sizes = {{Layout::LatLong, 256, 128}, {Layout::Healpix, 64, 0}};
  for (Size from : sizes)
    for (Size to : sizes) {
      const EnvMap dst = resample(constant_map(make(from), l), to.layout, to.width, to.height);
      double sum2 = 0;
      for (size_t i = 0; i < dst.pixel_count(); ++i) sum2 += std::pow(dst.pixel(i)[0] / l - 1.0, 2);
      EXPECT_LT(std::sqrt(sum2 / dst.pixel_count()), 0.08) << name(from) << " -> " << name(to);
    }
}

TEST(Resample, AHemisphereSourceMarksTheLowerHalfOfALatlongInvalid) {
  const EnvMap src = constant_map(make_hemisphere(360, 90), 1.0f);
  const int w = 256, h = 128;
  const EnvMap dst = resample(src, Layout::LatLong, w, h);
  ASSERT_EQ(dst.valid.size(), dst.pixel_count());
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u)
      ASSERT_EQ(dst.is_valid(size_t(v) * w + u), v < h / 2) << "pixel (" << u << ", " << v << ")";
  EXPECT_NEAR(total_power(dst)[0], 2 * M_PI, 1e-4 * 2 * M_PI);
}

TEST(Resample, InvalidSourcePixelsStayOutOfTheResult) {
  EnvMap src = constant_map(make_latlong(256, 128), 1.0f);
  src.valid.assign(src.pixel_count(), 1);
  for (size_t i = 0; i < src.pixel_count() / 2; ++i) src.valid[i] = 0;  // upper half unknown
  for (size_t i = 0; i < src.pixel_count() / 2; ++i) src.pixel(i)[0] = 1e6f;   // and not to be used
  const EnvMap dst = resample(src, Layout::Healpix, 32, 0);
  EXPECT_NEAR(total_power(dst)[0], 2 * M_PI, 1e-4 * 2 * M_PI);
  EXPECT_FALSE(dst.is_valid(0 + 4 * 32 * 32 * 0));  // pixel 0 of base pixel 0: northern cap
}

TEST(Resample, UnitsAreCopiedAndBadRequestsAreRejected) {
  EnvMap src = make_latlong(64, 32);
  src.units = Units::Radiance;
  EXPECT_EQ(resample(src, Layout::Healpix, 8, 0).units, Units::Radiance);
  EXPECT_THROW(resample(src, Layout::LatLong, 300, 100), InputError);
  EXPECT_THROW(resample(src, Layout::Healpix, 3, 0), InputError);
  ResampleOptions bad_k;
  bad_k.samples_per_edge = 3;
  EXPECT_THROW(resample(src, Layout::Healpix, 8, 0, bad_k), InputError);
  ResampleOptions not_rotation;
  not_rotation.world_from_source = Mat3{{2, 0, 0, 0, 1, 0, 0, 0, 1}};
  EXPECT_THROW(resample(src, Layout::LatLong, 64, 32, not_rotation), InputError);
}

TEST(Resample, MoreSamplesPerEdgeConvergeOnTheSameMap) {
  const EnvMap src = smooth_map(make_latlong(256, 128));
  ResampleOptions fine;
  fine.samples_per_edge = 16;
  const EnvMap a = resample(src, Layout::Healpix, 32, 0);
  const EnvMap b = resample(src, Layout::Healpix, 32, 0, fine);
  // The automatic choice agrees with 16 x 16 samples to a few percent RMS (worst near
  // the poles, where latlong pixels are slivers far smaller than typical), and 16 x 16
  // agrees with the analytic radiance at the pixel centres.
  double diff2 = 0, truth2 = 0;
  for (size_t i = 0; i < a.pixel_count(); ++i) {
    diff2 += std::pow(a.pixel(i)[1] - b.pixel(i)[1], 2);
    truth2 += std::pow(b.pixel(i)[1] - smooth_radiance(pixel_direction(b, i), 1), 2);
  }
  EXPECT_LT(std::sqrt(diff2 / a.pixel_count()), 0.03);
  EXPECT_LT(std::sqrt(truth2 / a.pixel_count()), 0.01);
  expect_power_near(total_power(b), total_power(src), 1e-4, "k = 16");
}


// ---- The exact path: row grids under identity, a yaw, Rx(180) or a composition -------

const Mat3 kRx180{{1, 0, 0, 0, -1, 0, 0, 0, -1}};

struct ExactCase {
  Size from, to;
  Mat3 rotation;
  std::string what;
};

std::vector<ExactCase> exact_cases() {
  const std::vector<std::array<Size, 2>> pairs = {
      {Size{Layout::Hemisphere, 360, 90}, Size{Layout::LatLong, 512, 256}},
      {Size{Layout::LatLong, 1024, 512}, Size{Layout::Hemisphere, 360, 90}},
      {Size{Layout::LatLong, 256, 128}, Size{Layout::LatLong, 100, 50}},
      {Size{Layout::LatLong, 256, 128}, Size{Layout::LatLong, 1000, 500}},
  };
  const std::vector<std::pair<Mat3, std::string>> rotations = {
      {Mat3{}, "identity"},
      {rotation_from_yaw_pitch_roll_deg(37, 0, 0), "yaw 37"},
      {kRx180, "Rx(180)"},
      {rotation_from_yaw_pitch_roll_deg(37, 0, 180), "yaw 37 after Rx(180)"},
  };
  std::vector<ExactCase> out;
  for (const auto& [from, to] : pairs)
    for (const auto& [r, rname] : rotations) out.push_back({from, to, r, name(from) + " -> " + name(to) + ", " + rname});
  return out;
}

bool flips(const Mat3& r) { return r(2, 2) < 0; }

// Power of a latlong/hemisphere source that lands in the destination's domain: all of
// it, unless the destination is a hemisphere, which keeps the source rows that end up
// above the horizon (the upper half, or the lower half under Rx(180)). Row grids with an
// even number of rows split exactly at the horizon.
std::array<double, 3> power_in_domain(const EnvMap& src, Layout to, bool flip) {
  if (to != Layout::Hemisphere || src.layout == Layout::Hemisphere) {
    if (src.layout == Layout::Hemisphere && to == Layout::Hemisphere && flip) return {0, 0, 0};
    return total_power(src);
  }
  std::array<double, 3> sum{0, 0, 0};
  for (size_t i = 0; i < src.pixel_count(); ++i) {
    const bool upper = int(i / size_t(src.width)) < src.height / 2;
    if (upper == flip || !src.is_valid(i)) continue;
    for (int c = 0; c < 3; ++c) sum[c] += pixel_solid_angle(src, i) * src.pixel(i)[c];
  }
  return sum;
}

TEST(Resample, AConstantMapStaysExactlyConstantBetweenRowGridsUnderAYawOrAHalfTurnAboutX) {
  const float l = 0.5f;
  for (const ExactCase& c : exact_cases()) {
    ResampleOptions options;
    options.world_from_source = c.rotation;
    const EnvMap dst = resample(constant_map(make(c.from), l), c.to.layout, c.to.width, c.to.height, options);
    size_t valid = 0;
    for (size_t i = 0; i < dst.pixel_count(); ++i) {
      const int v = int(i / size_t(dst.width));
      // A hemisphere source fills the upper half of a latlong (the lower under Rx(180)).
      bool want_valid = true;
      if (c.from.layout == Layout::Hemisphere) want_valid = (v < dst.height / 2) != flips(c.rotation);
      ASSERT_EQ(dst.is_valid(i), want_valid) << c.what << " pixel " << i;
      if (!want_valid) continue;
      ++valid;
      for (int ch = 0; ch < 3; ++ch) ASSERT_NEAR(dst.pixel(i)[ch], l, 1e-6 * l) << c.what << " pixel " << i;
    }
    EXPECT_GT(valid, 0u) << c.what;
  }
}

TEST(Resample, TheExactPathKeepsThePowerOfARandomMap) {
  std::mt19937 rng(12345);
  std::uniform_real_distribution<float> uniform(0.0f, 10.0f);
  for (const ExactCase& c : exact_cases()) {
    EnvMap src = make(c.from);
    for (float& x : src.rgb) x = uniform(rng);
    ResampleOptions options;
    options.world_from_source = c.rotation;
    const EnvMap dst = resample(src, c.to.layout, c.to.width, c.to.height, options);
    expect_power_near(total_power(dst), power_in_domain(src, c.to.layout, flips(c.rotation)), 1e-6, c.what);
  }
}

TEST(Resample, AOnePixelSunKeepsItsPowerAndDirectionOnTheExactPath) {
  for (const ExactCase& c : exact_cases()) {
    EnvMap src = make(c.from);
    // Suns at mid-latitudes, near the pole and at the phi = 0 seam, all in the part of
    // the source that the destination's domain receives.
    const bool upper = !(c.to.layout == Layout::Hemisphere && flips(c.rotation));
    for (const auto& [theta_deg, phi_deg] : std::vector<std::array<double, 2>>{{60, 123}, {3, 250}, {40, 0.1}}) {
      std::fill(src.rgb.begin(), src.rgb.end(), 0.0f);
      const double theta = (upper ? theta_deg : 180 - theta_deg) * M_PI / 180;
      const size_t sun = *pixel_at(src, direction_from_angles(theta, phi_deg * M_PI / 180));
      src.pixel(sun)[0] = 5e4f;
      src.pixel(sun)[1] = 4e4f;
      src.pixel(sun)[2] = 3e4f;
      ResampleOptions options;
      options.world_from_source = c.rotation;
      const EnvMap dst = resample(src, c.to.layout, c.to.width, c.to.height, options);
      const std::string what = c.what + ", sun at pixel " + std::to_string(sun);
      expect_power_near(total_power(dst), total_power(src), 1e-6, what);
      const Vec3 truth = c.rotation * mean_direction(src);
      EXPECT_LE(angle_between(mean_direction(dst), truth), half_pixel(dst, *pixel_at(dst, truth))) << what;
    }
  }
}

TEST(Resample, AHalfTurnAboutXSendsASunAtThetaThirtyPhiFortyToThetaOneFiftyPhiMinusForty) {
  const double deg = M_PI / 180;
  const Vec3 sun_dir = direction_from_angles(30 * deg, 40 * deg);
  const Vec3 want = direction_from_angles(150 * deg, -40 * deg);
  ResampleOptions options;
  options.world_from_source = kRx180;
  const int w = 512, h = 256;
  EnvMap src = make_latlong(w, h);
  const size_t sun = *pixel_at(src, sun_dir);
  src.pixel(sun)[0] = src.pixel(sun)[1] = src.pixel(sun)[2] = 1e4f;
  for (Size to : {Size{Layout::LatLong, w, h}, Size{Layout::LatLong, 200, 100}, Size{Layout::LatLong, 2048, 1024}}) {
    const EnvMap dst = resample(src, to.layout, to.width, to.height, options);
    expect_power_near(total_power(dst), total_power(src), 1e-6, name(to));
    const Vec3 got = mean_direction(dst);
    EXPECT_LE(angle_between(got, want), half_pixel(src, sun) + half_pixel(dst, *pixel_at(dst, want))) << name(to);
    EXPECT_LE(angle_between(got, kRx180 * mean_direction(src)), half_pixel(dst, *pixel_at(dst, want))) << name(to);
  }
  // Same grid: rows and columns map onto rows and columns, so the sun is moved, not
  // blurred: pixel (u, v) goes to (w - 1 - u, h - 1 - v), which holds theta = 150,
  // phi = -40 degrees.
  const EnvMap same = resample(src, Layout::LatLong, w, h, options);
  const size_t u = sun % w, v = sun / w, moved = (h - 1 - v) * w + (w - 1 - u);
  EXPECT_EQ(moved, *pixel_at(same, want));
  EXPECT_FLOAT_EQ(same.pixel(moved)[0], 1e4f);
  EXPECT_NEAR(total_power(same)[0], same.pixel(moved)[0] * pixel_solid_angle(same, moved), 1e-6 * total_power(same)[0]);
  // The hemigon sampler's use: the lower hemisphere of the world as a hemisphere map.
  EnvMap low = make_latlong(w, h);
  const size_t low_sun = *pixel_at(low, want);
  low.pixel(low_sun)[0] = low.pixel(low_sun)[1] = low.pixel(low_sun)[2] = 1e4f;
  const EnvMap hemi = resample(low, Layout::Hemisphere, 360, 90, options);
  expect_power_near(total_power(hemi), total_power(low), 1e-6, "lower hemisphere");
  EXPECT_LE(angle_between(mean_direction(hemi), sun_dir),
            half_pixel(low, low_sun) + half_pixel(hemi, *pixel_at(hemi, sun_dir)));
}

}  // namespace
}  // namespace lp
