// The overlay puts each light where CONVENTIONS.md's latlong puts its direction, in the
// light's own colour, over the map tone-mapped so that its 99th percentile shows at 0.8.
#include "sampling/overlay.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <set>

#include "core/error.h"
#include "core/image_io.h"

namespace lp {
namespace {

EnvMap uniform_latlong(int width, float r, float g, float b) {
  EnvMap map = make_latlong(width, width / 2);
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    map.pixel(i)[0] = r;
    map.pixel(i)[1] = g;
    map.pixel(i)[2] = b;
  }
  return map;
}

Light light_at(Vec3 d, std::array<double, 3> rgb) {
  Light l;
  l.direction = normalize(d);
  l.rgb = rgb;
  return l;
}

struct Rgb {
  float r, g, b;
};
Rgb at(const std::vector<float>& image, int width, int u, int v) {
  const float* p = &image[3 * (size_t(v) * size_t(width) + size_t(u))];
  return {p[0], p[1], p[2]};
}

TEST(Overlay, IsAWidthByHalfWidthRgbImageWhateverTheMapSize) {
  const EnvMap map = uniform_latlong(64, 1, 1, 1);
  EXPECT_EQ(render_overlay(map, {}, 64).size(), size_t(64 * 32 * 3));
  EXPECT_EQ(render_overlay(map, {}, 200).size(), size_t(200 * 100 * 3));
  EXPECT_EQ(render_overlay(map, {}, 32).size(), size_t(32 * 16 * 3));
}

TEST(Overlay, DrawsALightAtPhi90Theta90AtAQuarterOfTheWidthAndHalfTheHeight) {
  const int W = 256, H = W / 2;
  const EnvMap map = uniform_latlong(W, 0.2f, 0.2f, 0.2f);
  // phi = 90 deg, theta = 90 deg: +Y.
  const Light l = light_at(direction_from_angles(M_PI / 2, M_PI / 2), {3, 1.5, 0.6});
  const auto image = render_overlay(map, {l}, W);
  const Rgb p = at(image, W, W / 4, H / 2);
  EXPECT_NEAR(p.r, 1.0, 1e-6);  // the light's colour, rgb / max component
  EXPECT_NEAR(p.g, 0.5, 1e-6);
  EXPECT_NEAR(p.b, 0.2, 1e-6);
  // The opposite side (phi = 270 deg) is the map: uniform, so its 99th percentile, 0.8.
  const Rgb q = at(image, W, 3 * W / 4, H / 2);
  EXPECT_NEAR(q.r, 0.8, 1e-5);
  EXPECT_NEAR(q.g, 0.8, 1e-5);
  EXPECT_NEAR(q.b, 0.8, 1e-5);
  // And so is the zenith row above the light.
  EXPECT_NEAR(at(image, W, W / 4, 0).r, 0.8, 1e-5);
}

TEST(Overlay, MapsThe99thPercentileLuminanceTo0Point8WithReinhard) {
  const int W = 200, H = 100;
  EnvMap map = make_latlong(W, H);
  // Grey ramp: pixel i has luminance i + 1, so the 99th percentile (nearest rank) is
  // 0.99 * 20000 = 19800, held by pixel 19799.
  for (size_t i = 0; i < map.pixel_count(); ++i) map.pixel(i)[0] = map.pixel(i)[1] = map.pixel(i)[2] = float(i + 1);
  const auto image = render_overlay(map, {}, W);
  const double k = 4.0 / 19800;  // Reinhard: k Y / (1 + k Y) = 0.8
  for (size_t i : {size_t(0), size_t(5000), size_t(19799), size_t(19999)}) {
    const double y = double(i + 1);
    EXPECT_NEAR(image[3 * i], k * y / (1 + k * y), 1e-5) << "pixel " << i;
  }
  EXPECT_NEAR(image[3 * 19799], 0.8, 1e-5);
}

TEST(Overlay, DrawsInvalidPixelsAsANeutralCheckerboard) {
  const int W = 128, H = 64;
  EnvMap map = uniform_latlong(W, 5, 0, 0);
  map.valid.assign(map.pixel_count(), 1);
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W / 2; ++u) map.valid[size_t(v) * W + u] = 0;
  const auto image = render_overlay(map, {}, W);
  std::set<float> greys;
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      const Rgb p = at(image, W, u, v);
      if (u < W / 2) {
        EXPECT_EQ(p.r, p.g);
        EXPECT_EQ(p.g, p.b);
        EXPECT_GT(p.r, 0.2f);  // never black, which would look like darkness
        greys.insert(p.r);
      } else {
        EXPECT_GT(p.r, 0.5f);
        EXPECT_EQ(p.g, 0.0f);
      }
    }
  EXPECT_EQ(greys.size(), 2u);
}

TEST(Overlay, ALightOnTheSeamShowsAtBothEdges) {
  const int W = 128, H = 64;
  const EnvMap map = uniform_latlong(W, 0.2f, 0.2f, 0.2f);
  const auto image = render_overlay(map, {light_at({1, 0, 0}, {0, 2, 0})}, W);
  EXPECT_EQ(at(image, W, 0, H / 2).g, 1.0f);
  EXPECT_EQ(at(image, W, 0, H / 2).r, 0.0f);
  EXPECT_EQ(at(image, W, W - 1, H / 2).g, 1.0f);
  EXPECT_EQ(at(image, W, W - 1, H / 2).r, 0.0f);
}

TEST(Overlay, BrighterLightsGetLargerDiscsWithADarkOutline) {
  const int W = 512, H = 256;
  const EnvMap map = uniform_latlong(W, 0.2f, 0.2f, 0.2f);
  const Light bright = light_at(direction_from_angles(M_PI / 2, M_PI / 2), {0, 1000, 0});
  const Light dim = light_at(direction_from_angles(M_PI / 2, 3 * M_PI / 2), {0, 0, 1});
  const auto image = render_overlay(map, {bright, dim}, W);
  int green = 0, blue = 0;
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      const Rgb p = at(image, W, u, v);
      green += p.r == 0 && p.g == 1 && p.b == 0;
      blue += p.r == 0 && p.g == 0 && p.b == 1;
    }
  EXPECT_GT(blue, 0);
  EXPECT_GT(green, 2 * blue);
  // Walking right from the bright light's centre: its colour, then a dark outline, then
  // the map within a few pixels (default radius W / 128 = 4 px).
  int u = W / 4;
  while (u < W / 4 + 20 && at(image, W, u, H / 2).g == 1) ++u;
  EXPECT_GE(u - W / 4, 3);
  const Rgb edge = at(image, W, u, H / 2);
  EXPECT_LT(edge.r + edge.g + edge.b, 0.2f);
  EXPECT_NEAR(at(image, W, u + 2, H / 2).r, 0.8, 1e-5);
}

TEST(Overlay, ResamplesAHemisphereMapAndChecksTheLowerHalf) {
  EnvMap map = make_hemisphere(360, 90);
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    map.pixel(i)[0] = 0.5f;  // orange sky: valid pixels have r > g, the checker r == g
    map.pixel(i)[1] = 0.25f;
    map.pixel(i)[2] = 0;
  }
  const int W = 128, H = 64;
  const auto image = render_overlay(map, {}, W);
  ASSERT_EQ(image.size(), size_t(W * H * 3));
  for (int u = 0; u < W; u += 7) {
    for (int v : {0, H / 4, H / 2 - 3}) {  // the sky
      const Rgb sky = at(image, W, u, v);
      EXPECT_GT(sky.r, 1.5f * sky.g) << u << ", " << v;
      EXPECT_GT(sky.r, 0.3f) << u << ", " << v;
    }
    for (int v : {H / 2 + 2, 3 * H / 4, H - 1}) {  // no data below the horizon
      const Rgb below = at(image, W, u, v);
      EXPECT_EQ(below.r, below.g);
      EXPECT_TRUE(below.r == 0.45f || below.r == 0.55f) << below.r;
    }
  }
}

TEST(Overlay, RejectsAnOddOrEmptyWidth) {
  const EnvMap map = uniform_latlong(64, 1, 1, 1);
  EXPECT_THROW(render_overlay(map, {}, 63), InputError);
  EXPECT_THROW(render_overlay(map, {}, 0), InputError);
}

TEST(Overlay, WritesAPngOfTheMapsWidth) {
  const int W = 64, H = 32;
  const EnvMap map = uniform_latlong(W, 0.2f, 0.2f, 0.2f);
  const auto path = (std::filesystem::temp_directory_path() / "lightprobe_overlay_test.png").string();
  write_overlay_png(path, map, {light_at({0, 1, 0}, {3, 1.5, 0.6})});
  const CameraImage back = read_camera_image(path);
  std::filesystem::remove(path);
  EXPECT_EQ(back.width, W);
  EXPECT_EQ(back.height, H);
  const float* p = &back.rgb[3 * (size_t(H / 2) * W + W / 4)];
  EXPECT_NEAR(p[0], 1.0, 1e-6);  // sRGB-encoded 1.0 is still 255
  EXPECT_GT(p[1], 0.5);          // 0.5 linear encodes to ~0.735
}

}  // namespace
}  // namespace lp
