#include "core/resample.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
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

}  // namespace
}  // namespace lp
