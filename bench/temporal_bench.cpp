// Per-frame cost of the whole live back end (prepare + place + temporal processing) for
// each method: n = 300 on a 360x90 polar map and n = 1000 on a 1024x512 latlong map.
// Frames alternate between the scene and a copy with 1 % pixel noise, so that the
// incremental and filtering paths do real work every frame.
#include <benchmark/benchmark.h>

#include <map>
#include <random>
#include <vector>

#include "eval/synthetic_scene.h"
#include "sampling/frame_pipeline.h"

namespace {

using namespace lp;

const std::vector<EnvMap>& frames_for(Layout layout) {
  static std::map<Layout, std::vector<EnvMap>> cache;
  auto it = cache.find(layout);
  if (it != cache.end()) return it->second;
  const bool polar = layout == Layout::Hemisphere;
  EnvMap base = render_scene(describe_scene(), layout, polar ? 360 : 1024, polar ? 90 : 512);
  std::vector<EnvMap> frames;
  std::mt19937 rng(3);
  std::normal_distribution<float> noise(1.0f, 0.01f);
  for (int f = 0; f < 4; ++f) {
    EnvMap m = base;
    if (f % 2)
      for (float& v : m.rgb) v *= std::max(0.0f, noise(rng));
    frames.push_back(std::move(m));
  }
  return cache.emplace(layout, std::move(frames)).first->second;
}

void BM_LiveFrame(benchmark::State& state, Method method, Layout layout, bool filter, int cluster) {
  const auto& frames = frames_for(layout);
  FramePipelineOptions o;
  o.method = method;
  o.count = layout == Layout::Hemisphere ? 300 : 1000;
  o.sampler.upper_only = layout == Layout::Hemisphere;
  o.filter = filter ? FilterMode::On : FilterMode::Off;
  o.cluster_max_lights = cluster;
  FramePipeline pipeline(o);
  int64_t f = 0;
  for (const EnvMap& m : frames) pipeline.process(m, f++, 0);  // warm the caches
  for (auto _ : state) {
    benchmark::DoNotOptimize(pipeline.process(frames[size_t(f % 4)], f, 0));
    ++f;
  }
}

int register_all() {
  for (Layout layout : {Layout::Hemisphere, Layout::LatLong}) {
    const std::string size = layout == Layout::Hemisphere ? "hemisphere360x90/n300" : "latlong1024x512/n1000";
    for (Method m : all_methods()) {
      const std::string name = std::string(to_string(m)) + "/" + size;
      benchmark::RegisterBenchmark(("LiveFrame/" + name).c_str(), BM_LiveFrame, m, layout, false, 0)
          ->Unit(benchmark::kMicrosecond);
      benchmark::RegisterBenchmark(("LiveFrame+FIR/" + name).c_str(), BM_LiveFrame, m, layout, true, 0)
          ->Unit(benchmark::kMicrosecond);
      benchmark::RegisterBenchmark(("LiveFrame+FIR+cluster64/" + name).c_str(), BM_LiveFrame, m, layout, true, 64)
          ->Unit(benchmark::kMicrosecond);
    }
  }
  return 0;
}
const int registered = register_all();

}  // namespace
