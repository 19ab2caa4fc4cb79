#include "probe/fill.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"

namespace lp {
namespace {

TEST(Fill, PushPullFillsAHoleInAUniformMapWithTheSameColourAndKeepsTheMask) {
  EnvMap m = make_latlong(64, 32);
  m.valid.assign(m.pixel_count(), 1);
  for (size_t i = 0; i < m.pixel_count(); ++i) {
    m.rgb[3 * i] = 2.0f;
    m.rgb[3 * i + 1] = 1.0f;
    m.rgb[3 * i + 2] = 0.5f;
  }
  for (int v = 16; v < 32; ++v)  // the lower hemisphere, as below a fisheye's horizon
    for (int u = 0; u < 64; ++u) {
      const size_t i = size_t(v) * 64 + u;
      m.valid[i] = 0;
      m.rgb[3 * i] = m.rgb[3 * i + 1] = m.rgb[3 * i + 2] = 0.0f;
    }
  FillReport report;
  fill_invalid(m, {}, &report);
  for (size_t i = 0; i < m.pixel_count(); ++i) {
    EXPECT_NEAR(m.rgb[3 * i], 2.0f, 1e-5);
    EXPECT_NEAR(m.rgb[3 * i + 2], 0.5f, 1e-5);
  }
  EXPECT_EQ(report.filled_pixels, 16u * 64u);
  EXPECT_NEAR(report.filled_solid_angle, 2 * M_PI, 1e-9);
  EXPECT_NEAR(report.filled_power_share, 0.5, 1e-6);
  EXPECT_EQ(m.valid[m.pixel_count() - 1], 0);  // mask kept
}

TEST(Fill, PushPullKeepsValidPixelsAndStaysWithinTheRangeOfTheRim) {
  EnvMap m = make_hemisphere(90, 30);
  m.valid.assign(m.pixel_count(), 1);
  for (int v = 0; v < 30; ++v)
    for (int u = 0; u < 90; ++u) {
      const size_t i = size_t(v) * 90 + u;
      const float value = 1.0f + float(u) / 10.0f;  // ramp in azimuth
      m.rgb[3 * i] = m.rgb[3 * i + 1] = m.rgb[3 * i + 2] = value;
      if (u >= 40 && u < 50 && v >= 10 && v < 20) m.valid[i] = 0;
    }
  const EnvMap before = m;
  fill_invalid(m);
  for (size_t i = 0; i < m.pixel_count(); ++i) {
    if (before.valid[i]) {
      EXPECT_EQ(m.rgb[3 * i], before.rgb[3 * i]);
    } else {
      EXPECT_GE(m.rgb[3 * i], 1.0f + 3.9f);  // rim spans 5.0 .. 5.0 + 0.9 (and neighbours)
      EXPECT_LE(m.rgb[3 * i], 1.0f + 5.0f);
    }
  }
}

TEST(Fill, PushPullOnHealpixFillsFromTheNestedHierarchy) {
  EnvMap m = make_healpix(8);
  m.valid.assign(m.pixel_count(), 1);
  for (size_t i = 0; i < m.pixel_count(); ++i) m.rgb[3 * i] = m.rgb[3 * i + 1] = m.rgb[3 * i + 2] = 3.0f;
  for (size_t i = 0; i < 64; ++i) m.valid[i] = 0;  // base pixel 0 entirely
  fill_invalid(m, {.keep_mask = false});
  EXPECT_TRUE(m.valid.empty());
  for (size_t i = 0; i < 64; ++i) EXPECT_NEAR(m.rgb[3 * i], 3.0f, 1e-5);
}

TEST(Fill, AMapWithNoValidPixelCannotBePushPulled) {
  EnvMap m = make_latlong(8, 4);
  m.valid.assign(m.pixel_count(), 0);
  EXPECT_THROW(fill_invalid(m), InputError);
}

}  // namespace
}  // namespace lp
