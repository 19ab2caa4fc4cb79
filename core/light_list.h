// The light list of CONVENTIONS.md: the product's main output.
//   { "format": "lightprobe.lights/1", "frame": 42, "timestamp": 1700000000.123,
//     "method": "q2tree", "units": "relative" | "radiance", "frame_convention": "z-up",
//     "lights": [ { "id": 17, "direction": [x, y, z], "rgb": [r, g, b], "solid_angle": s } ],
//     "sh9": { "order": 2, "content": "residual" | "map", "coefficients": [[r, g, b] x 9] } }
// "sh9" is optional (core/spherical_harmonics.h has its convention). "residual": the
// radiance the lights leave out, to be added to them as unshadowed ambient (lights + SH
// hold the map's power); "map": the whole map, an alternative to the lights, not an
// addition.
// rgb is the integral of radiance over the region a light stands for, so that
// E(n) = sum_i rgb_i max(0, n . d_i); direction points from the scene towards the light.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/envmap.h"
#include "core/spherical_harmonics.h"
#include "core/vec3.h"

namespace lp {

struct Light {
  uint64_t id = 0;  // stable across frames (Halton index, HEALPix NUNIQ node, ...)
  Vec3 direction;
  std::array<double, 3> rgb{0, 0, 0};
  double solid_angle = 0;  // steradians of the region this light stands for
  double luminance() const { return lp::luminance(rgb.data()); }
};

enum class Sh9Content { Map, Residual };
std::string_view to_string(Sh9Content content);

struct LightList {
  int64_t frame = 0;
  double timestamp = 0;
  std::string method;
  Units units = Units::Relative;
  std::vector<Light> lights;
  std::optional<Sh9> sh9;  // ambient SH9, see above
  Sh9Content sh9_content = Sh9Content::Residual;
};

inline constexpr const char* kLightListFormat = "lightprobe.lights/1";

// One JSON object; `pretty` indents it, otherwise one line (NDJSON).
std::string to_json(const LightList& list, bool pretty = true);
// Parse one object; throws InputError naming `source` on a malformed document.
LightList light_list_from_json(const std::string& text, const std::string& source = "light list");

std::array<double, 3> total_power(const std::vector<Light>& lights);

}  // namespace lp
