#include "probe/stabilise.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>

#include "core/envmap.h"
#include "core/error.h"
#include "probe/fisheye.h"

namespace lp {
namespace {

TEST(Stabilise, SmoothingAOnePixelJitteredStaticTrackLeavesLessThanAFifthOfAPixel) {
  std::mt19937 rng(42);
  std::normal_distribution<double> noise(0.0, 1.0);
  const double true_cx = 640.3, true_cy = 481.7, true_r = 455.0;
  CircleTrack raw;
  for (int i = 0; i < 600; ++i) {
    raw.cx.push_back(true_cx + noise(rng));
    raw.cy.push_back(true_cy + noise(rng));
    raw.r.push_back(true_r + noise(rng));
  }
  raw.cx[100] += 40;  // a missed detection
  const CircleTrack s = smooth_track(raw);
  double worst = 0, ss = 0;
  for (size_t i = 0; i < s.cx.size(); ++i) {
    const double e = std::hypot(s.cx[i] - true_cx, s.cy[i] - true_cy);
    worst = std::max(worst, e);
    ss += e * e;
  }
  const double rms = std::sqrt(ss / s.cx.size());
  std::printf("raw jitter %.3f px, smoothed %.4f px, rms error vs truth %.3f px, worst %.3f px\n",
              residual_jitter_px(raw), residual_jitter_px(s), rms, worst);
  EXPECT_GT(residual_jitter_px(raw), 1.2);  // 1 px per axis: ~1.41 (plus the outlier)
  EXPECT_LT(residual_jitter_px(s), 0.02);
  EXPECT_LT(rms, 0.2);
  EXPECT_LT(worst, 0.5);
  const CircleTrack st = smooth_track(raw, {.static_probe = true});
  EXPECT_LT(std::hypot(st.cx[0] - true_cx, st.cy[0] - true_cy), 0.2);
  EXPECT_EQ(residual_jitter_px(st), 0.0);
}

TEST(Stabilise, SmoothingFollowsSlowDrift) {
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 1.0);
  CircleTrack raw;
  for (int i = 0; i < 600; ++i) {
    raw.cx.push_back(100 + 0.01 * i + noise(rng));  // 6 px over the track
    raw.cy.push_back(80 + noise(rng));
    raw.r.push_back(50);
  }
  const CircleTrack s = smooth_track(raw);
  double ss = 0;
  for (int i = 0; i < 600; ++i) ss += std::pow(s.cx[i] - (100 + 0.01 * i), 2);
  EXPECT_LT(std::sqrt(ss / 600), 0.3);
}

TEST(Stabilise, TracksOfUnequalLengthAreRefused) {
  CircleTrack t{{1, 2}, {1}, {1, 2}};
  EXPECT_THROW(smooth_track(t), InputError);
}

TEST(Stabilise, FindsTheImageCircleOfASyntheticFisheyeWithinHalfAPixel) {
  EnvMap sky = make_latlong(128, 64);
  for (size_t i = 0; i < sky.pixel_count(); ++i) {
    const Vec3 d = pixel_direction(sky, i);
    const float v = float(0.3 + 0.7 * std::max(0.0, d.z) + 0.2 * d.x);
    sky.rgb[3 * i] = sky.rgb[3 * i + 1] = sky.rgb[3 * i + 2] = std::max(v, 0.05f);
  }
  FisheyeModel m = equidistant_fisheye(320, 240, 180);  // circle radius 120 px
  m.fx = m.fy = 100.0 / (M_PI / 2);                     // radius 100 px instead
  m.cx = 151.3;
  m.cy = 118.6;
  const RgbImage photo = render_fisheye(sky, m, 8);
  const ImageCircle c = find_image_circle(photo);
  std::printf("found (%.3f, %.3f) r %.3f, rms %.3f px over %d points\n", c.cx, c.cy, c.r, c.rms_residual_px,
              c.boundary_points);
  EXPECT_NEAR(c.cx, 151.3, 0.5);
  EXPECT_NEAR(c.cy, 118.6, 0.5);
  EXPECT_NEAR(c.r, 100.0, 0.5);
}

TEST(Stabilise, FindsTheImageCircleOfTheSkyCamPhotoNearItsCentre) {
  const std::string dir = std::string(LIGHTPROBE_SHARED_DATA) + "/hdr-allsky-skycam-stack";
  std::string path;
  if (std::filesystem::exists(dir))
    for (const auto& e : std::filesystem::directory_iterator(dir))
      if (e.path().filename().string().ends_with("_12_image.png")) path = e.path().string();
  if (path.empty()) GTEST_SKIP() << "no SkyCam data in " << dir;
  const RgbImage photo = read_rgb_image(path);
  ASSERT_EQ(photo.width, 300);
  ASSERT_EQ(photo.height, 300);
  const ImageCircle c = find_image_circle(photo);
  std::printf("SkyCam circle (%.2f, %.2f) r %.2f, rms %.2f px over %d points\n", c.cx, c.cy, c.r,
              c.rms_residual_px, c.boundary_points);
  EXPECT_NEAR(c.cx, 149.5, 15);
  EXPECT_NEAR(c.cy, 149.5, 15);
  EXPECT_GT(c.r, 100);
  EXPECT_LT(c.r, 150);
}

TEST(Stabilise, AnImageWithoutADiscIsRefused) {
  RgbImage flat;
  flat.width = flat.height = 32;
  flat.rgb.assign(32 * 32 * 3, 0.5f);
  EXPECT_THROW(find_image_circle(flat), InputError);
}

}  // namespace
}  // namespace lp
