#include "eval/synthetic_scene.h"

#include <gtest/gtest.h>

#include <cmath>

namespace lp {
namespace {

SceneOptions sun_only() {
  SceneOptions o;
  o.sky_scale = 0;
  o.area_lights = false;
  return o;
}

// Angular size (rad) of half a pixel's diagonal near direction d.
double half_pixel(const EnvMap& map, Vec3 d) {
  if (map.layout == Layout::Healpix) return 0.5 * std::sqrt(2.0) * std::sqrt(4 * M_PI / double(map.pixel_count()));
  const double span = map.layout == Layout::Hemisphere ? M_PI / 2 : M_PI;
  const double dtheta = span / map.height, dphi = 2 * M_PI / map.width;
  const double s = std::sin(zenith_of(d)) + dtheta;
  return 0.5 * std::hypot(dtheta, s * dphi);
}

struct Size {
  Layout layout;
  int width, height;
};

TEST(SyntheticScene, SunAloneCarriesExactlyItsAnalyticPowerAtAnyResolution) {
  const SceneDescription scene = describe_scene(sun_only());
  const auto expected = scene.sun_power();
  const double omega = 2 * M_PI * (1 - std::cos(0.27 * M_PI / 180));
  EXPECT_DOUBLE_EQ(expected[0], 200000.0 * omega);
  for (Size s : {Size{Layout::LatLong, 64, 32}, Size{Layout::LatLong, 1024, 512}, Size{Layout::Hemisphere, 360, 90},
                 Size{Layout::Healpix, 64, 0}}) {
    const EnvMap map = render_scene(scene, s.layout, s.width, s.height);
    SCOPED_TRACE(describe_size(map));
    const auto power = total_power(map);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(power[c] / expected[c], 1.0, 1e-6) << "channel " << c;

    // The power-weighted direction of the map is the sun's, to within half a pixel.
    Vec3 centroid;
    for (size_t i = 0; i < map.pixel_count(); ++i) {
      const float* p = map.pixel(i);
      const double y = luminance(p[0], p[1], p[2]) * pixel_solid_angle(map, i);
      centroid = centroid + y * pixel_direction(map, i);
    }
    const Vec3 sun = scene.options.sun_direction;
    EXPECT_LT(angle_between(normalize(centroid), sun), half_pixel(map, sun));
  }
}

TEST(SyntheticScene, FullScenePowerAgreesBetweenLayouts) {
  const SceneDescription scene = describe_scene();
  const auto a = total_power(render_scene(scene, Layout::LatLong, 1024, 512));
  const auto b = total_power(render_scene(scene, Layout::Healpix, 128, 0));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(a[c] / b[c], 1.0, 1e-3) << "channel " << c;
}

TEST(SyntheticScene, DefaultSunCarriesAboutSixtyPercentOfThePower) {
  const SceneDescription scene = describe_scene();
  const auto sun = scene.sun_power();
  const double fraction = luminance(sun.data()) / total_luminance_power(render_scene(scene, Layout::Healpix, 64, 0));
  EXPECT_GT(fraction, 0.55);
  EXPECT_LT(fraction, 0.65);
}

TEST(SyntheticScene, AreaLightsAddTheirAnalyticCapPower) {
  SceneOptions o;
  o.sun_rgb = {0, 0, 0};
  const SceneDescription with = describe_scene(o);
  o.area_lights = false;
  const SceneDescription without = describe_scene(o);
  ASSERT_EQ(with.emitters.size(), 3u);
  EXPECT_TRUE(without.emitters.empty());
  std::array<double, 3> expected{0, 0, 0};
  for (const SceneEmitter& e : with.emitters) {
    EXPECT_GT(e.direction.z, 0) << "emitters are above the horizon";
    const double omega = 2 * M_PI * (1 - std::cos(e.half_angle_deg * M_PI / 180));
    for (int c = 0; c < 3; ++c) expected[c] += e.rgb[c] * omega;
  }
  const auto a = total_power(render_scene(with, Layout::LatLong, 512, 256));
  const auto b = total_power(render_scene(without, Layout::LatLong, 512, 256));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR((a[c] - b[c]) / expected[c], 1.0, 2e-3) << "channel " << c;
}

TEST(SyntheticScene, SkyIsBlueAboveAndGroundIsDimBelow) {
  const SceneDescription scene = describe_scene();
  const auto zenith = scene_radiance_without_sun(scene, {0, 0, 1});
  const auto nadir = scene_radiance_without_sun(scene, {0, 0, -1});
  const auto horizon = scene_radiance_without_sun(scene, normalize({-1, -0.2, 0.05}));
  EXPECT_GT(zenith[2], zenith[0]);
  EXPECT_GT(luminance(horizon.data()), luminance(zenith.data()));
  EXPECT_LT(luminance(nadir.data()), 0.2);
  EXPECT_GT(luminance(nadir.data()), 0.0);
  SceneOptions dark;
  dark.sky_scale = 0;
  dark.area_lights = false;
  const auto none = scene_radiance_without_sun(describe_scene(dark), {0, 0, 1});
  EXPECT_EQ(none[0] + none[1] + none[2], 0.0);
}

TEST(SyntheticScene, PixelsAverageTheRadianceOverTheirArea) {
  // A smooth region: a pixel's value is close to the radiance at its centre.
  const SceneDescription scene = describe_scene();
  const EnvMap map = render_scene(scene, Layout::LatLong, 256, 128);
  const size_t i = 10 * 256 + 200;
  const auto L = scene_radiance_without_sun(scene, pixel_direction(map, i));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(map.pixel(i)[c], L[c], 1e-2 * L[c]);
}

}  // namespace
}  // namespace lp
