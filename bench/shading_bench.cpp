// Many-light shading (Havran 2005, section 4): per-point cost of each shader variant, and
// the per-frame cost of building the tables (culling lists, glossy sets, clustering), on
// the procedural scene's pharr lights. Range: |H| = 256 and 4096.
#include <benchmark/benchmark.h>

#include <map>
#include <memory>

#include "eval/synthetic_scene.h"
#include "render/reference_shader.h"
#include "sampling/sampler.h"

namespace {

using namespace lp;

const EnvMap& scene_map() {
  static const EnvMap map = render_scene(describe_scene(), Layout::LatLong, 1024, 512);
  return map;
}

std::shared_ptr<const AngularRegions> culling_regions() {
  static auto r = std::make_shared<const AngularRegions>(ShadingOptions{}.regions);
  return r;
}
std::shared_ptr<const AngularRegions> cone_regions() {
  static auto r = std::make_shared<const AngularRegions>(ShadingOptions{}.glossy.cone_regions);
  return r;
}

const std::vector<Light>& low_lights(int high) {
  static std::map<int, std::vector<Light>> cache;
  auto it = cache.find(high);
  if (it == cache.end())
    it = cache.emplace(high, sample(scene_map(), high * ShadingOptions{}.glossy.low_per_high, Method::Pharr).lights).first;
  return it->second;
}

// Per-region copies (range(1) = 1) or index lists into one light array (0).
const ShadingScene& scene_for(int high, bool copies = false) {
  static std::map<std::pair<int, bool>, ShadingScene> cache;
  auto it = cache.find({high, copies});
  if (it == cache.end()) {
    ShadingOptions o;
    o.region_copies = copies;
    it = cache.emplace(std::pair{high, copies}, prepare_shading(low_lights(high), high, culling_regions(), cone_regions(), o)).first;
  }
  return it->second;
}

void BM_Shade(benchmark::State& state, ShadingVariant variant) {
  const int high = int(state.range(0));
  const ShadingScene& s = scene_for(high, state.range(1) != 0);
  std::vector<Vec3> normals, reflections;
  make_shading_points(1024, 7, normals, reflections);
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(shade(s, variant, normals[i], reflections[i], 100));
    i = (i + 1) % normals.size();
  }
  state.SetItemsProcessed(state.iterations());  // shaded points
}

// One point shaded again and again: its lists stay in cache, which isolates the
// arithmetic from the memory traffic of jumping between regions.
void BM_ShadeHotCache(benchmark::State& state, ShadingVariant variant) {
  const ShadingScene& s = scene_for(int(state.range(0)), state.range(1) != 0);
  std::vector<Vec3> normals, reflections;
  make_shading_points(64, 7, normals, reflections);
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(shade(s, variant, normals[i / 4096 % 64], reflections[i / 4096 % 64], 100));
    ++i;
  }
  state.SetItemsProcessed(state.iterations());
}

void BM_PrepareShadingTables(benchmark::State& state) {
  const int high = int(state.range(0));
  const auto& low = low_lights(high);
  ShadingOptions o;
  o.region_copies = state.range(1) != 0;
  for (auto _ : state) benchmark::DoNotOptimize(prepare_shading(low, high, culling_regions(), cone_regions(), o));
}

void BM_BuildRegions(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(AngularRegions(AngularRegionOptions{int(state.range(0)), 64}));
}

}  // namespace

// Args: |H|, region copies (1) or index lists (0).
BENCHMARK_CAPTURE(BM_Shade, all, ShadingVariant::All)->Args({256, 0})->Args({4096, 0});
BENCHMARK_CAPTURE(BM_Shade, culled, ShadingVariant::Culled)->ArgsProduct({{256, 4096}, {0, 1}});
BENCHMARK_CAPTURE(BM_Shade, glossy, ShadingVariant::Glossy)->ArgsProduct({{256, 4096}, {0, 1}});
BENCHMARK_CAPTURE(BM_Shade, clustered, ShadingVariant::Clustered)->ArgsProduct({{256, 4096}, {0, 1}});
BENCHMARK_CAPTURE(BM_ShadeHotCache, all, ShadingVariant::All)->Args({256, 0})->Args({4096, 0});
BENCHMARK_CAPTURE(BM_ShadeHotCache, culled, ShadingVariant::Culled)->ArgsProduct({{256, 4096}, {0, 1}});
BENCHMARK(BM_PrepareShadingTables)->ArgsProduct({{256, 4096}, {0, 1}})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_BuildRegions)->Arg(256)->Arg(1024)->Unit(benchmark::kMillisecond);
