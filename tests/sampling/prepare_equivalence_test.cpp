// The fast prepare passes (sampling/row_sweep.h and each method's prepare) choose the same
// lights as the plain scalar passes they replaced: every method samples the shared probes
// and synthetic maps (latlong, hemisphere, healpix, masked, odd sizes) and the light list
// (ids, directions, rgb, solid angles, bit for bit) is hashed and compared with the hash
// the scalar prepare gave before the change (commit 7cef003, recorded below). A hash that
// differs means a light moved, changed colour or changed id by at least one bit. Lists that
// changed on purpose (hemigon on night.exr, q2tree on row-grid maps, see the digests file)
// have their tolerance tested in hemigon_test.cpp and q2tree_float_bins_test.cpp.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "core/envmap.h"
#include "core/image_io.h"
#include "eval/synthetic_scene.h"
#include "sampling/sampler.h"

namespace lp {
namespace {

const std::string kData = LIGHTPROBE_SHARED_DATA;

// FNV-1a over the bytes of every field of every light, in list order.
uint64_t digest(const std::vector<Light>& lights) {
  uint64_t h = 1469598103934665603ull;
  auto eat = [&](const void* p, size_t n) {
    const auto* b = static_cast<const unsigned char*>(p);
    for (size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 1099511628211ull;
  };
  for (const Light& l : lights) {
    eat(&l.id, sizeof l.id);
    const double d[7] = {l.direction.x, l.direction.y, l.direction.z, l.rgb[0], l.rgb[1], l.rgb[2], l.solid_angle};
    eat(d, sizeof d);
  }
  return h;
}

EnvMap masked(EnvMap map) {
  map.valid.assign(map.pixel_count(), 1);
  for (size_t i = 0; i < map.pixel_count(); i += 7) map.valid[i] = 0;  // scattered holes
  for (size_t i = map.pixel_count() / 3; i < map.pixel_count() / 2; ++i) map.valid[i] = 0;  // a band
  return map;
}

// The maps, by name: the shared probes when present, synthetic scenes always.
EnvMap map_named(const std::string& name) {
  const auto scene = describe_scene();
  if (name == "scene_latlong1024") return render_scene(scene, Layout::LatLong, 1024, 512);
  if (name == "scene_latlong_odd") return render_scene(scene, Layout::LatLong, 202, 101);
  if (name == "scene_hemisphere") return render_scene(scene, Layout::Hemisphere, 360, 90);
  if (name == "scene_healpix") return render_scene(scene, Layout::Healpix, 32, 0);
  if (name == "scene_masked") return masked(render_scene(scene, Layout::LatLong, 256, 128));
  if (name == "grace") return read_envmap(kData + "/probes-probulator-latlong256/grace.hdr");
  if (name == "sunrise") return read_envmap(kData + "/probes-blender-studiolights/sunrise.exr");
  if (name == "night") return read_envmap(kData + "/probes-blender-studiolights/night.exr");
  if (name == "city") return read_envmap(kData + "/probes-blender-studiolights/city.exr");
  if (name == "grace_masked") return masked(read_envmap(kData + "/probes-probulator-latlong256/grace.hdr"));
  return {};
}

struct Case {
  const char* map;
  Method method;
  bool upper_only;
  uint64_t n50, n300;  // digests of place(50) and place(300) from the scalar prepare
};

// Recorded from the scalar prepare passes at commit 7cef003.
const Case kCases[] = {
#include "prepare_equivalence_digests.inc"
};

bool needs_shared_data(const std::string& name) { return name.rfind("scene_", 0) != 0; }

TEST(PrepareEquivalence, EveryMethodChoosesTheLightsOfTheScalarPrepareBitForBit) {
  std::string last;
  EnvMap map;
  int compared = 0;
  for (const Case& c : kCases) {
    if (c.map != last) {
      last = c.map;
      if (needs_shared_data(last) && !std::filesystem::exists(kData)) continue;
      map = map_named(last);
    }
    if (map.pixel_count() == 0) continue;
    SamplerOptions options;
    options.upper_only = c.upper_only;
    auto sampler = make_sampler(c.method, options);
    sampler->prepare(map);
    const uint64_t d50 = digest(sampler->place(50)), d300 = digest(sampler->place(300));
    if (c.n50 == 0 && c.n300 == 0) {  // recording mode: print the line to paste above
      std::printf("  {\"%s\", Method::%s, %s, 0x%016llxull, 0x%016llxull},\n", c.map,
                  c.method == Method::Pharr ? "Pharr" : c.method == Method::Hemigon ? "Hemigon"
                  : c.method == Method::Q2Tree ? "Q2Tree" : "MedianCut",
                  c.upper_only ? "true" : "false", (unsigned long long)d50, (unsigned long long)d300);
      ADD_FAILURE() << "no digest recorded";
      continue;
    }
    EXPECT_EQ(d50, c.n50) << c.map << " " << to_string(c.method) << (c.upper_only ? " upper_only" : "") << " n=50";
    EXPECT_EQ(d300, c.n300) << c.map << " " << to_string(c.method) << (c.upper_only ? " upper_only" : "") << " n=300";
    if (c.method == Method::Q2Tree) {  // a sampler's first frame takes the plain loop, later ones the vector kernel
      sampler->prepare(map);
      EXPECT_EQ(digest(sampler->place(50)), c.n50) << c.map << " q2tree, second frame, n=50";
      EXPECT_EQ(digest(sampler->place(300)), c.n300) << c.map << " q2tree, second frame, n=300";
    }
    ++compared;
  }
  EXPECT_GE(compared, 20);
}

// The q2tree keeps its tree between frames: a sequence of maps through one sampler gives
// the lights of the scalar prepare on every frame.
TEST(PrepareEquivalence, Q2TreeAcrossFramesChoosesTheLightsOfTheScalarPrepare) {
  const auto scene = describe_scene();
  EnvMap a = render_scene(scene, Layout::LatLong, 256, 128);
  EnvMap b = a;
  for (size_t i = 0; i < b.rgb.size(); ++i) b.rgb[i] *= 1.0f + 0.25f * float((i * 2654435761u) % 97) / 97.0f;
  auto sampler = make_sampler(Method::Q2Tree);
  uint64_t h = 0;
  for (const EnvMap* m : {&a, &b, &a}) {
    sampler->prepare(*m);
    h = h * 31 + digest(sampler->place(120));
  }
  // 0x15d718930704f7f9 before q2tree's float node sums (see the digests file).
  EXPECT_EQ(h, 0x2de6675c0cb932a7ull) << std::hex << h;
}

}  // namespace
}  // namespace lp
