// render_fake_scene (probe/camera_source.h): the Aravis fake camera's scene as radiance.
// Built into the probe library (tests, benchmarks) and into the camera plugin (which paints it).
#include <algorithm>
#include <cmath>

#include "probe/camera_source.h"

namespace lp {

RgbImage render_fake_scene(const FakeScene& scene, int width, int height) {
  RgbImage image;
  image.width = width, image.height = height;
  image.rgb.assign(size_t(std::max(0, width)) * std::max(0, height) * 3, 0.0f);
  const double cx = 0.5 * (width - 1), cy = 0.5 * (height - 1);
  const double radius = scene.circle_radius * std::min(width, height);
  if (radius <= 0) return image;
  const double deg = M_PI / 180;
  const double se = scene.sun_elevation_deg * deg, sa = scene.sun_azimuth_deg * deg;
  const double sun[3] = {std::cos(se) * std::cos(sa), std::cos(se) * std::sin(sa), std::sin(se)};
  const double cos_sun = std::cos(scene.sun_radius_deg * deg);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const double dx = x - cx, dy = cy - y;
      const double r = std::hypot(dx, dy) / radius;
      if (r > 1) continue;
      const double theta = r * M_PI / 2;  // zenith angle, equidistant fisheye
      const double phi = std::atan2(dy, dx);
      const double d[3] = {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
      const bool in_sun = d[0] * sun[0] + d[1] * sun[1] + d[2] * sun[2] >= cos_sun;
      const double t = theta / (M_PI / 2);
      float* px = &image.rgb[(size_t(y) * width + x) * 3];
      for (int c = 0; c < 3; ++c)
        px[c] = float(in_sun ? scene.sun_radiance[c] : (1 - t) * scene.sky_zenith[c] + t * scene.sky_horizon[c]);
    }
  return image;
}

}  // namespace lp
