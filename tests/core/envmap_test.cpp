#include "core/envmap.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "core/error.h"

namespace lp {
namespace {

double total_solid_angle(const EnvMap& map) {
  double sum = 0;
  for (size_t i = 0; i < map.pixel_count(); ++i) sum += pixel_solid_angle(map, i);
  return sum;
}

TEST(EnvMap, LatlongSolidAnglesSumToFourPi) {
  EXPECT_NEAR(total_solid_angle(make_latlong(64, 32)), 4 * M_PI, 1e-6);
  EXPECT_NEAR(total_solid_angle(make_latlong(1024, 512)), 4 * M_PI, 1e-6);
}

TEST(EnvMap, HemisphereSolidAnglesSumToTwoPi) {
  EXPECT_NEAR(total_solid_angle(make_hemisphere(360, 90)), 2 * M_PI, 1e-6);
  EXPECT_NEAR(layout_solid_angle(Layout::Hemisphere), 2 * M_PI, 1e-15);
}

TEST(EnvMap, HealpixSolidAnglesSumToFourPi) {
  for (int nside : {1, 16, 128}) {
    const EnvMap map = make_healpix(nside);
    EXPECT_EQ(map.pixel_count(), size_t(12 * nside * nside));
    EXPECT_NEAR(total_solid_angle(map), 4 * M_PI, 1e-6) << "nside " << nside;
  }
}

TEST(EnvMap, LatlongPixelSolidAngleIsTheExactBandArea) {
  // Row v of an H-row map spans theta in [pi v / H, pi (v + 1) / H]; each of W pixels
  // gets 2 pi / W of the band's area 2 pi (cos theta0 - cos theta1).
  const EnvMap map = make_latlong(64, 32);
  const double expected_row0 = (2 * M_PI / 64) * (1 - std::cos(M_PI / 32));
  EXPECT_NEAR(pixel_solid_angle(map, 0), expected_row0, 1e-15);
  EXPECT_NEAR(pixel_solid_angle(map, 63), expected_row0, 1e-15);
  const double expected_row16 = (2 * M_PI / 64) * (std::cos(M_PI * 16 / 32) - std::cos(M_PI * 17 / 32));
  EXPECT_NEAR(pixel_solid_angle(map, 16 * 64 + 5), expected_row16, 1e-15);
}

TEST(EnvMap, LatlongPixelZeroCentreMatchesTheConventionsFormula) {
  const int w = 64, h = 32;
  const EnvMap map = make_latlong(w, h);
  const double phi = 2 * M_PI * 0.5 / w, theta = M_PI * 0.5 / h;
  const Vec3 d = pixel_direction(map, 0);
  EXPECT_NEAR(d.x, std::sin(theta) * std::cos(phi), 1e-15);
  EXPECT_NEAR(d.y, std::sin(theta) * std::sin(phi), 1e-15);
  EXPECT_NEAR(d.z, std::cos(theta), 1e-15);
  // Row 0 is straight up, phi grows from +X towards +Y along a row.
  EXPECT_GT(d.z, 0.99);
  const Vec3 quarter = pixel_direction(map, 16 * 64 + 16);  // row 16, u = 16
  EXPECT_NEAR(azimuth_of(quarter), 2 * M_PI * 16.5 / w, 1e-12);
  EXPECT_GT(quarter.y, 0.99);
}

TEST(EnvMap, HemispherePixelCentreMatchesTheConventionsFormula) {
  const EnvMap map = make_hemisphere(360, 90);
  const size_t u = 10, v = 89;
  const Vec3 d = pixel_direction(map, v * 360 + u);
  const double phi = 2 * M_PI * (u + 0.5) / 360, theta = (M_PI / 2) * (v + 0.5) / 90;
  EXPECT_NEAR(d.x, std::sin(theta) * std::cos(phi), 1e-15);
  EXPECT_NEAR(d.y, std::sin(theta) * std::sin(phi), 1e-15);
  EXPECT_NEAR(d.z, std::cos(theta), 1e-15);
}

void expect_round_trip(const EnvMap& map) {
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    const Vec3 d = pixel_direction(map, i);
    ASSERT_NEAR(length(d), 1.0, 1e-12) << describe_size(map) << " pixel " << i;
    const auto back = pixel_at(map, d);
    ASSERT_TRUE(back.has_value()) << describe_size(map) << " pixel " << i;
    ASSERT_EQ(*back, i) << describe_size(map);
  }
}

TEST(EnvMap, PixelDirectionAndPixelAtRoundTripForEveryPixel) {
  expect_round_trip(make_latlong(16, 8));
  expect_round_trip(make_latlong(64, 32));
  expect_round_trip(make_hemisphere(24, 6));
  expect_round_trip(make_hemisphere(360, 90));
  for (int nside : {1, 2, 4, 8}) expect_round_trip(make_healpix(nside));
}

TEST(EnvMap, HemisphereHasNoPixelBelowTheHorizon) {
  const EnvMap map = make_hemisphere(360, 90);
  EXPECT_FALSE(pixel_at(map, Vec3{0, 0, -1}).has_value());
  EXPECT_FALSE(pixel_at(map, normalize(Vec3{1, 0, -0.01})).has_value());
  EXPECT_TRUE(pixel_at(map, normalize(Vec3{1, 0, 0.01})).has_value());
}

TEST(EnvMap, LatlongThatIsNotTwoToOneIsRejected) {
  EXPECT_THROW(make_latlong(300, 100), InputError);
  EXPECT_THROW(make_latlong(0, 0), InputError);
  EXPECT_NO_THROW(make_latlong(300, 150));
}

TEST(EnvMap, HealpixNsideThatIsNotAPowerOfTwoIsRejected) {
  EXPECT_THROW(make_healpix(3), InputError);
  EXPECT_THROW(make_healpix(0), InputError);
  EXPECT_NO_THROW(make_healpix(4));
}

TEST(EnvMap, TotalPowerOfAConstantMapIsFourPiTimesItsRadiance) {
  const float l[3] = {0.5f, 2.0f, 3.0f};
  for (EnvMap map : {make_latlong(64, 32), make_healpix(16), make_hemisphere(360, 90)}) {
    for (size_t i = 0; i < map.pixel_count(); ++i)
      for (int c = 0; c < 3; ++c) map.pixel(i)[c] = l[c];
    const double omega = map.layout == Layout::Hemisphere ? 2 * M_PI : 4 * M_PI;
    const auto p = total_power(map);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(p[c], omega * l[c], 1e-9 * omega * l[c]) << describe_size(map);
    EXPECT_NEAR(total_luminance_power(map), omega * luminance(l[0], l[1], l[2]), 1e-6);
  }
}

TEST(EnvMap, TotalPowerSkipsInvalidPixels) {
  EnvMap map = make_healpix(4);
  for (float& v : map.rgb) v = 1.0f;
  map.valid.assign(map.pixel_count(), 1);
  map.valid[0] = map.valid[7] = 0;
  const auto p = total_power(map);
  EXPECT_NEAR(p[0], 4 * M_PI * (map.pixel_count() - 2) / map.pixel_count(), 1e-12);
}

TEST(EnvMap, FindBadPixelNamesNanInfAndNegativePixels) {
  EnvMap map = make_latlong(16, 8);
  EXPECT_EQ(find_bad_pixel(map, "sky.exr"), "");
  map.pixel(2 * 16 + 3)[1] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(find_bad_pixel(map, "sky.exr"), "sky.exr: pixel (3, 2) is NaN");
  map.pixel(2 * 16 + 3)[1] = 0;
  map.pixel(5 * 16 + 15)[2] = std::numeric_limits<float>::infinity();
  EXPECT_EQ(find_bad_pixel(map, "sky.exr"), "sky.exr: pixel (15, 5) is infinite");
  map.pixel(5 * 16 + 15)[2] = 0;
  map.pixel(7 * 16 + 0)[0] = -1e-3f;
  EXPECT_EQ(find_bad_pixel(map, "sky.exr"), "sky.exr: pixel (0, 7) is negative");

  // The edges of the bit test that answers "none" first: -0, the largest float and the
  // smallest denormal pass; the smallest negative denormal, a negative NaN and a value
  // beside the last one fail.
  map.pixel(7 * 16 + 0)[0] = -0.0f;
  map.pixel(1)[1] = std::numeric_limits<float>::max();
  map.pixel(2)[2] = std::numeric_limits<float>::denorm_min();
  EXPECT_EQ(find_bad_pixel(map, "sky.exr"), "");
  map.pixel(4)[0] = -std::numeric_limits<float>::denorm_min();
  EXPECT_EQ(find_bad_pixel(map, "sky.exr"), "sky.exr: pixel (4, 0) is negative");
  map.pixel(4)[0] = -std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(find_bad_pixel(map, "sky.exr"), "sky.exr: pixel (4, 0) is NaN");
  map.pixel(4)[0] = 0;
  map.pixel(map.pixel_count() - 1)[2] = -1;
  EXPECT_EQ(find_bad_pixel(map, "sky.exr"), "sky.exr: pixel (15, 7) is negative");

  EnvMap hp = make_healpix(2);
  hp.pixel(13)[0] = -std::numeric_limits<float>::infinity();
  EXPECT_EQ(find_bad_pixel(hp, "probe.exr"), "probe.exr: healpix pixel 13 is infinite");
}

TEST(EnvMap, LayoutAndUnitNamesRoundTrip) {
  for (Layout l : {Layout::LatLong, Layout::Hemisphere, Layout::Healpix})
    EXPECT_EQ(layout_from_string(to_string(l)), l);
  EXPECT_FALSE(layout_from_string("cubemap").has_value());
  EXPECT_EQ(units_from_string(to_string(Units::Radiance)), Units::Radiance);
  EXPECT_EQ(describe_size(make_healpix(64)), "healpix nside 64");
  EXPECT_EQ(describe_size(make_latlong(1024, 512)), "latlong 1024x512");
}

}  // namespace
}  // namespace lp
