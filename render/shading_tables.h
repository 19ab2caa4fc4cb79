// Export of a frame's shading tables (angular regions, their light lists, the lights) so a
// renderer can use them without our code: JSON for tools, and one RGBA32F texture a
// shader uploads as is.
//
// Three tables, each self-contained (its own LUT, lists and lights):
//   kind 0 "diffuse"   S_H culling regions over H (reach pi/2): diffuse and glossy-outside-cone
//   kind 1 "cone"      S_L regions over L (reach = cone half-angle): glossy inside the cone
//   kind 2 "clusters"  S_H culling regions over H clustered to at most Q lights (shadow casters)
//
// Binary file (little-endian): 8 bytes "LPSHADE1", uint32 width, uint32 height, then
// width * height texels of 4 float32 (RGBA32F, row-major). Integers are stored as floats
// (exact below 2^24). Texel indices below are linear: texel k is at (k % width, k / width).
//   texel 0                 (version = 1, table count T, width, used texels)
//   texels 1 + 3t .. 3 + 3t directory of table t:
//       (kind, region count M, LUT face size F, light count N)
//       (lut start, offsets start, indices start, lights start)     texel indices
//       (cos of the cone half-angle (0 if none), k = max cone lights (0 if none),
//        index count, centres start)
//   LUT      6 F^2 region ids, 4 per texel; id of LUT entry (face * F + t) * F + s with the
//            OpenGL cube-map addressing of angular_regions.h
//   offsets  M + 1 values, 4 per texel: region j lists entries offsets[j] .. offsets[j+1]
//   indices  index count values, 4 per texel: light numbers 0..N-1, ascending per region
//   centres  one texel per region: (x, y, z, radius alpha in radians)
//   lights   two texels per light: (x, y, z, luminance), (r, g, b, solid angle)
// Each section starts on a new texel; unused lanes and the padding are 0.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/light_list.h"
#include "render/reference_shader.h"

namespace lp {

inline constexpr const char* kShadingTablesFormat = "lightprobe.shading_tables/1";
inline constexpr int kShadingTextureWidth = 1024;

// One JSON object: format, frame_convention, cube_map convention, and per table its kind,
// name, face size, cone half-angle, k, LUT, regions (centre, radius, light numbers) and
// lights (id, direction, rgb, solid_angle as in the light list).
std::string shading_tables_json(const ShadingScene& scene, const LightList& meta);

// The binary file above.
std::string shading_tables_binary(const ShadingScene& scene);

// A decoded binary file (for tests and tools): the texel array and an accessor.
struct ShadingTexture {
  uint32_t width = 0, height = 0;
  std::vector<float> texels;  // 4 floats per texel
  std::array<float, 4> texel(size_t k) const { return {texels[4 * k], texels[4 * k + 1], texels[4 * k + 2], texels[4 * k + 3]}; }
  float value(size_t start, size_t i) const { return texels[4 * start + i]; }  // i-th packed value of a section
};
// Throws InputError naming `source` on a wrong magic or a truncated file.
ShadingTexture read_shading_texture(const std::string& bytes, const std::string& source = "shading tables");

}  // namespace lp
