// Shading-table export: a reader that knows only the documented layout (not our structs)
// finds, for any direction, the same region, list and lights as the library; the JSON
// holds the same tables; a foreign or truncated file is a clear error.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <memory>
#include <random>

#include "core/error.h"
#include "eval/synthetic_scene.h"
#include "sampling/sampler.h"
#include "render/shading_tables.h"

namespace lp {
namespace {

ShadingScene small_scene() {
  static const EnvMap map = render_scene(describe_scene(), Layout::LatLong, 128, 64);
  ShadingOptions o;
  o.glossy.low_per_high = 4;
  o.glossy.max_cone_lights = 32;
  auto regions = std::make_shared<const AngularRegions>(AngularRegionOptions{60, 16});
  auto cones = std::make_shared<const AngularRegions>(AngularRegionOptions{150, 16});
  return prepare_shading(sample(map, 512, Method::Pharr).lights, 128, regions, cones, o);
}

// The documented OpenGL cube-map addressing, written out again here on purpose.
int texel_of(Vec3 d, int f) {
  const double ax = std::fabs(d.x), ay = std::fabs(d.y), az = std::fabs(d.z);
  int face;
  double sc, tc, ma;
  if (ax >= ay && ax >= az) face = d.x >= 0 ? 0 : 1, ma = ax, sc = d.x >= 0 ? -d.z : d.z, tc = -d.y;
  else if (ay >= az) face = d.y >= 0 ? 2 : 3, ma = ay, sc = d.x, tc = d.y >= 0 ? d.z : -d.z;
  else face = d.z >= 0 ? 4 : 5, ma = az, sc = d.z >= 0 ? d.x : -d.x, tc = -d.y;
  const int s = std::min(f - 1, int(f * 0.5 * (sc / ma + 1))), t = std::min(f - 1, int(f * 0.5 * (tc / ma + 1)));
  return (face * f + t) * f + s;
}

TEST(ShadingTables, BinaryLayoutAsDocumentedGivesTheLibrarysListsAndLights) {
  const ShadingScene s = small_scene();
  const std::string bytes = shading_tables_binary(s);
  const ShadingTexture tex = read_shading_texture(bytes);
  EXPECT_EQ(tex.width, uint32_t(kShadingTextureWidth));
  const auto head = tex.texel(0);
  EXPECT_EQ(head[0], 1.0f);
  ASSERT_EQ(head[1], 3.0f);
  EXPECT_LE(size_t(head[3]), size_t(tex.width) * tex.height);

  const std::vector<Light>* lights[3] = {&s.lights, &s.glossy.low, &s.clustered};
  const RegionLights* lists[3] = {&s.culled, &s.glossy.low_regions, &s.clustered_regions};
  const AngularRegions* regions[3] = {s.regions.get(), s.cone_regions.get(), s.regions.get()};
  std::mt19937 rng(1);
  std::normal_distribution<double> g;
  for (int t = 0; t < 3; ++t) {
    const auto d0 = tex.texel(size_t(1 + 3 * t)), d1 = tex.texel(size_t(2 + 3 * t)), d2 = tex.texel(size_t(3 + 3 * t));
    EXPECT_EQ(int(d0[0]), t);  // kind
    EXPECT_EQ(int(d0[1]), regions[t]->count());
    const int f = int(d0[2]);
    EXPECT_EQ(f, regions[t]->face_size());
    EXPECT_EQ(size_t(d0[3]), lights[t]->size());
    const size_t lut = size_t(d1[0]), offsets = size_t(d1[1]), indices = size_t(d1[2]), light0 = size_t(d1[3]);
    EXPECT_EQ(size_t(d2[2]), lists[t]->indices.size());
    if (t == 1) {
      EXPECT_NEAR(d2[0], std::cos(s.glossy.cone_half_angle), 1e-6);
      EXPECT_EQ(int(d2[1]), s.glossy.max_cone_lights);
    }
    const size_t centres = size_t(d2[3]);
    for (int k = 0; k < 300; ++k) {
      const Vec3 dir = normalize({g(rng), g(rng), g(rng)});
      const int region = int(tex.value(lut, size_t(texel_of(dir, f))));
      ASSERT_EQ(region, regions[t]->region_of(dir));
      EXPECT_NEAR(tex.texel(centres + size_t(region))[3], regions[t]->radius()[size_t(region)], 1e-6);
      const size_t b = size_t(tex.value(offsets, size_t(region))), e = size_t(tex.value(offsets, size_t(region) + 1));
      ASSERT_EQ(e - b, lists[t]->size(region));
      for (size_t q = b; q < e; ++q) {
        const size_t i = size_t(tex.value(indices, q));
        ASSERT_EQ(i, lists[t]->indices[q]);
        const auto a = tex.texel(light0 + 2 * i), c = tex.texel(light0 + 2 * i + 1);
        const Light& l = (*lights[t])[i];
        EXPECT_FLOAT_EQ(a[0], float(l.direction.x));
        EXPECT_FLOAT_EQ(a[2], float(l.direction.z));
        EXPECT_FLOAT_EQ(a[3], float(l.luminance()));
        EXPECT_FLOAT_EQ(c[1], float(l.rgb[1]));
        EXPECT_FLOAT_EQ(c[3], float(l.solid_angle));
      }
    }
  }
}

TEST(ShadingTables, JsonHoldsTheSameTables) {
  const ShadingScene s = small_scene();
  LightList meta;
  meta.method = "pharr";
  const auto doc = nlohmann::json::parse(shading_tables_json(s, meta));
  EXPECT_EQ(doc["format"], kShadingTablesFormat);
  EXPECT_EQ(doc["frame_convention"], "z-up");
  ASSERT_EQ(doc["tables"].size(), 3u);
  const auto& diffuse = doc["tables"][0];
  EXPECT_EQ(diffuse["name"], "diffuse");
  EXPECT_EQ(diffuse["lut"].size(), size_t(6 * 16 * 16));
  ASSERT_EQ(diffuse["regions"].size(), 60u);
  ASSERT_EQ(diffuse["lights"].size(), s.lights.size());
  for (int j = 0; j < 60; ++j) {
    const auto list = diffuse["regions"][size_t(j)]["lights"].get<std::vector<uint32_t>>();
    EXPECT_EQ(list.size(), s.culled.size(j));
    if (!list.empty()) {
      EXPECT_EQ(list.front(), s.culled.indices[s.culled.offsets[size_t(j)]]);
    }
  }
  EXPECT_EQ(diffuse["lights"][5]["id"].get<uint64_t>(), s.lights[5].id);
  EXPECT_NEAR(doc["tables"][1]["cone_half_angle"].get<double>(), s.glossy.cone_half_angle, 1e-12);
  EXPECT_EQ(doc["tables"][2]["lights"].size(), s.clustered.size());
}

TEST(ShadingTables, ForeignOrTruncatedFilesAreClearErrors) {
  EXPECT_THROW(read_shading_texture("GARBAGE-not-a-table", "x.bin"), InputError);
  std::string bytes = shading_tables_binary(small_scene());
  bytes.resize(bytes.size() - 4);
  try {
    read_shading_texture(bytes, "t.bin");
    FAIL() << "no throw";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("t.bin"), std::string::npos);
  }
}

}  // namespace
}  // namespace lp
