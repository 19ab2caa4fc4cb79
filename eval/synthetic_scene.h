// The project's own procedural test scene, rendered at any layout and resolution with
// known ground truth: a sky gradient over a dim ground, a small very bright sun disc and a
// few dimmer area lights (two windows and a lamp). Pixels are the exact average of the
// analytic radiance over their area (supersampled; the sun disc, far smaller than a pixel
// at usual sizes, is integrated separately so that its power is exact at any resolution).
#pragma once

#include <array>
#include <vector>

#include "core/envmap.h"
#include "core/vec3.h"

namespace lp {

struct SceneOptions {
  // Sun: direction, angular radius (deg) and radiance; the default radiance makes the sun
  // carry ~ 60 % of the map's luminance power (60.2 %) from 5.5e-6 of the sphere.
  Vec3 sun_direction = direction_from_angles(50.0 * M_PI / 180.0, 30.0 * M_PI / 180.0);
  double sun_radius_deg = 0.27;
  std::array<double, 3> sun_rgb{200000.0, 180000.0, 150000.0};
  double sky_scale = 1.0;          // multiplies sky, ground and area lights
  bool area_lights = true;
  int samples_per_edge = 4;        // supersampling of the smooth part per pixel edge
};

// A rectangle-ish emitter: the spherical cap of the given half-angle (a "window" or "lamp").
struct SceneEmitter {
  Vec3 direction;
  double half_angle_deg = 5;
  std::array<double, 3> rgb{0, 0, 0};  // radiance
};

// Everything that defines the scene, for tests that need the ground truth.
struct SceneDescription {
  SceneOptions options;
  std::vector<SceneEmitter> emitters;
  // Power (integral of radiance) of the sun alone, per channel.
  std::array<double, 3> sun_power() const;
};
SceneDescription describe_scene(const SceneOptions& options = {});

// Radiance of the smooth part (sky, ground, emitters; no sun) in direction d.
std::array<double, 3> scene_radiance_without_sun(const SceneDescription& scene, Vec3 d);

// Render into the layout/size (healpix: width = nside).
EnvMap render_scene(const SceneDescription& scene, Layout layout, int width, int height);

}  // namespace lp
