// Shading-table export: JSON and the one-texture binary described in shading_tables.h.
#include "render/shading_tables.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <bit>
#include <cstring>

#include "core/error.h"

namespace lp {
namespace {

static_assert(std::endian::native == std::endian::little, "the binary export assumes a little-endian host");

struct TableView {
  int kind;
  const char* name;
  const AngularRegions* regions;
  const RegionLights* lists;
  const std::vector<Light>* lights;
  double cone_half_angle;  // 0: none
  int max_cone_lights;     // 0: none
};

std::vector<TableView> tables_of(const ShadingScene& s) {
  return {{0, "diffuse", s.regions.get(), &s.culled, &s.lights, 0.0, 0},
          {1, "cone", s.cone_regions.get(), &s.glossy.low_regions, &s.glossy.low, s.glossy.cone_half_angle,
           s.glossy.max_cone_lights},
          {2, "clusters", s.regions.get(), &s.clustered_regions, &s.clustered, 0.0, 0}};
}

nlohmann::json light_json(const Light& l) {
  return {{"id", l.id},
          {"direction", {l.direction.x, l.direction.y, l.direction.z}},
          {"rgb", {l.rgb[0], l.rgb[1], l.rgb[2]}},
          {"solid_angle", l.solid_angle}};
}

// Texels as a growing float array; sections start on a texel boundary.
struct Writer {
  std::vector<float> f;
  size_t texel() const { return f.size() / 4; }
  void align() {
    while (f.size() % 4) f.push_back(0);
  }
  size_t section() {
    align();
    return texel();
  }
  void exact_int(size_t v, const char* what) {
    if (v >= (size_t(1) << 24)) throw InputError(fmt::format("shading tables: {} = {} is too large for a float texture", what, v));
    f.push_back(float(v));
  }
};

}  // namespace

std::string shading_tables_json(const ShadingScene& scene, const LightList& meta) {
  nlohmann::json tables = nlohmann::json::array();
  for (const TableView& t : tables_of(scene)) {
    nlohmann::json regions = nlohmann::json::array();
    for (int j = 0; j < t.regions->count(); ++j) {
      const Vec3 c = t.regions->centres()[size_t(j)];
      const auto b = t.lists->indices.begin() + t.lists->offsets[size_t(j)];
      const auto e = t.lists->indices.begin() + t.lists->offsets[size_t(j) + 1];
      regions.push_back({{"centre", {c.x, c.y, c.z}},
                         {"radius", t.regions->radius()[size_t(j)]},
                         {"lights", std::vector<uint32_t>(b, e)}});
    }
    nlohmann::json lights = nlohmann::json::array();
    for (const Light& l : *t.lights) lights.push_back(light_json(l));
    tables.push_back({{"kind", t.kind},
                      {"name", t.name},
                      {"face_size", t.regions->face_size()},
                      {"reach", t.lists->reach},
                      {"cone_half_angle", t.cone_half_angle},
                      {"max_cone_lights", t.max_cone_lights},
                      {"lut", t.regions->lut()},
                      {"regions", regions},
                      {"lights", lights}});
  }
  nlohmann::json doc = {{"format", kShadingTablesFormat},
                        {"frame", meta.frame},
                        {"timestamp", meta.timestamp},
                        {"method", meta.method},
                        {"units", std::string(to_string(meta.units))},
                        {"frame_convention", "z-up"},
                        {"cube_map", "opengl: faces +X,-X,+Y,-Y,+Z,-Z; lut[(face*F+t)*F+s]"},
                        {"tables", tables}};
  return doc.dump(1) + "\n";
}

std::string shading_tables_binary(const ShadingScene& scene) {
  const auto tables = tables_of(scene);
  Writer w;
  w.f.assign(4 * (1 + 3 * tables.size()), 0.0f);  // header and directory, filled below
  for (size_t t = 0; t < tables.size(); ++t) {
    const TableView& tv = tables[t];
    const size_t lut = w.section();
    for (int32_t id : tv.regions->lut()) w.exact_int(size_t(id), "region id");
    const size_t offsets = w.section();
    for (uint32_t o : tv.lists->offsets) w.exact_int(o, "list offset");
    const size_t indices = w.section();
    for (uint32_t i : tv.lists->indices) w.exact_int(i, "light number");
    const size_t centres = w.section();
    for (int j = 0; j < tv.regions->count(); ++j) {
      const Vec3 c = tv.regions->centres()[size_t(j)];
      w.f.insert(w.f.end(), {float(c.x), float(c.y), float(c.z), float(tv.regions->radius()[size_t(j)])});
    }
    const size_t lights = w.section();
    for (const Light& l : *tv.lights)
      w.f.insert(w.f.end(), {float(l.direction.x), float(l.direction.y), float(l.direction.z), float(l.luminance()),
                             float(l.rgb[0]), float(l.rgb[1]), float(l.rgb[2]), float(l.solid_angle)});
    float* d = &w.f[4 * (1 + 3 * t)];
    const float dir[12] = {float(tv.kind), float(tv.regions->count()), float(tv.regions->face_size()),
                           float(tv.lights->size()), float(lut), float(offsets), float(indices), float(lights),
                           tv.cone_half_angle > 0 ? float(std::cos(tv.cone_half_angle)) : 0.0f,
                           float(tv.max_cone_lights), float(tv.lists->indices.size()), float(centres)};
    std::memcpy(d, dir, sizeof dir);
  }
  w.align();
  const size_t used = w.texel();
  if (used >= (size_t(1) << 24)) throw InputError("shading tables: the texture would exceed 2^24 texels");
  const uint32_t width = kShadingTextureWidth;
  const uint32_t height = uint32_t((used + width - 1) / width);
  w.f.resize(size_t(width) * height * 4, 0.0f);
  const float head[4] = {1.0f, float(tables.size()), float(width), float(used)};
  std::memcpy(w.f.data(), head, sizeof head);

  std::string bytes(16 + w.f.size() * 4, '\0');
  std::memcpy(bytes.data(), "LPSHADE1", 8);
  std::memcpy(bytes.data() + 8, &width, 4);
  std::memcpy(bytes.data() + 12, &height, 4);
  std::memcpy(bytes.data() + 16, w.f.data(), w.f.size() * 4);
  return bytes;
}

ShadingTexture read_shading_texture(const std::string& bytes, const std::string& source) {
  if (bytes.size() < 16 || std::memcmp(bytes.data(), "LPSHADE1", 8) != 0)
    throw InputError(fmt::format("{}: not a lightprobe shading-table file (no LPSHADE1 magic)", source));
  ShadingTexture t;
  std::memcpy(&t.width, bytes.data() + 8, 4);
  std::memcpy(&t.height, bytes.data() + 12, 4);
  const size_t floats = size_t(t.width) * t.height * 4;
  if (t.width == 0 || bytes.size() != 16 + floats * 4)
    throw InputError(fmt::format("{}: truncated shading-table file ({} bytes for {}x{} texels)", source, bytes.size(),
                                 t.width, t.height));
  t.texels.resize(floats);
  std::memcpy(t.texels.data(), bytes.data() + 16, floats * 4);
  return t;
}

}  // namespace lp
