#include "core/map_statistics.h"

#include <gtest/gtest.h>

#include <cmath>

namespace lp {
namespace {

// HEALPix pixels all have the solid angle 4 pi / 12 nside^2, so every number has a closed form.
TEST(MapStatistics, GreyRampOnHealpixMatchesClosedForms) {
  EnvMap map = make_healpix(16);  // 3072 pixels
  const size_t n = map.pixel_count(), valid = 3000;
  map.valid.assign(n, 0);
  for (size_t i = 0; i < n; ++i) {
    // Valid pixels hold 1 .. 3000; the invalid ones a value that must not count.
    const float v = i < valid ? float(i + 1) : 1e6f;
    map.rgb[3 * i] = map.rgb[3 * i + 1] = map.rgb[3 * i + 2] = v;
    map.valid[i] = i < valid;
  }
  const MapStatistics s = map_statistics(map);
  EXPECT_EQ(s.pixels, n);
  EXPECT_EQ(s.valid, valid);
  EXPECT_NEAR(s.min_positive, 1, 1e-5);
  EXPECT_NEAR(s.max, 3000, 1e-2);
  EXPECT_NEAR(s.mean, 1500.5, 1e-2);
  EXPECT_NEAR(s.median, 1501, 1e-2);  // nearest rank round(0.5 * 2999) = 1500 of 0-based ranks
  EXPECT_NEAR(s.p99, 2970, 1e-2);     // round(0.99 * 2999) = 2969
  EXPECT_NEAR(s.range_stops, std::log2(3000.0), 1e-5);
  const double omega = 4 * M_PI / double(n);
  EXPECT_NEAR(s.power_luminance, 3000.0 * 3001.0 / 2 * omega, 1e-5 * s.power_luminance);
  EXPECT_NEAR(s.power_rgb[1], 3000.0 * 3001.0 / 2 * omega, 1e-6 * s.power_luminance);
  // The brightest 0.1 %: the top 3 of 3000 pixels.
  EXPECT_NEAR(s.top_power_share, (3000.0 + 2999 + 2998) / (3000.0 * 3001.0 / 2), 1e-6);
  const Vec3 d = pixel_direction(map, valid - 1);
  EXPECT_DOUBLE_EQ(s.brightest_direction.x, d.x);
  EXPECT_DOUBLE_EQ(s.brightest_direction.z, d.z);
  const nlohmann::json j = s.to_json(map);
  EXPECT_EQ(j["nside"], 16);
  EXPECT_EQ(j["layout"], "healpix");
  EXPECT_NEAR(j["valid_fraction"].get<double>(), 3000.0 / 3072.0, 1e-12);
  EXPECT_NEAR(j["luminance"]["p99"].get<double>(), 2970, 1e-2);
}

TEST(MapStatistics, BlackMapHasNoRangeAndNoPeak) {
  const EnvMap map = make_latlong(16, 8);
  const MapStatistics s = map_statistics(map);
  EXPECT_EQ(s.valid, map.pixel_count());
  EXPECT_EQ(s.min_positive, 0);
  EXPECT_EQ(s.range_stops, 0);
  EXPECT_EQ(s.power_luminance, 0);
  EXPECT_EQ(s.top_power_share, 0);
  EXPECT_FALSE(s.to_json(map).contains("nside"));
}

}  // namespace
}  // namespace lp
