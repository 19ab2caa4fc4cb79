// Speed of every sampler on the two map sizes that matter: the 360x90 polar map of a live
// fisheye (Havran 2005) and a 1024x512 latlong probe. Each time is also reported as a
// multiple of one plain pass over the same map's memory (x_read), the floor no method
// can beat:  build/bench/lightprobe_bench --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <map>
#include <vector>

#include "bench/evict_caches.h"
#include "core/accuracy.h"
#include "core/spherical_harmonics.h"
#include "core/temporal_tonemap.h"
#include "eval/synthetic_scene.h"
#include "sampling/sampler.h"

namespace {

using namespace lp;

const EnvMap& scene_map(Layout layout) {
  static std::map<Layout, EnvMap> cache;
  auto it = cache.find(layout);
  if (it == cache.end()) {
    const auto scene = describe_scene();
    it = cache.emplace(layout, layout == Layout::Hemisphere ? render_scene(scene, layout, 360, 90)
                                                              : render_scene(scene, layout, 1024, 512)).first;
  }
  return it->second;
}

// One plain pass over the map: read every float once (the luminance of every pixel).
double plain_read_seconds(const EnvMap& map) {
  std::vector<double> t;
  for (int r = 0; r < 50; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    float s = 0;
    const float* p = map.rgb.data();
    const size_t n = map.pixel_count();
    for (size_t i = 0; i < n; ++i) s += 0.2126f * p[3 * i] + 0.7152f * p[3 * i + 1] + 0.0722f * p[3 * i + 2];
    benchmark::DoNotOptimize(s);
    t.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

// Reports the time per iteration as a multiple of one plain read of the map. Timed by
// hand around the loop because counters cannot see the benchmark's own clock.
class RatioTimer {
 public:
  RatioTimer(benchmark::State& state, const EnvMap& map) : state_(state), map_(map) {}
  ~RatioTimer() {
    static std::map<const EnvMap*, double> read;
    if (!read.count(&map_)) read[&map_] = plain_read_seconds(map_);
    const double per_iteration = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count() /
                                 double(std::max<benchmark::IterationCount>(1, state_.iterations()));
    state_.counters["x_read"] = per_iteration / read[&map_];
  }

 private:
  benchmark::State& state_;
  const EnvMap& map_;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

void BM_PlainRead(benchmark::State& state, Layout layout) {
  const EnvMap& map = scene_map(layout);
  RatioTimer ratio(state, map);
  for (auto _ : state) {
    float s = 0;
    const float* p = map.rgb.data();
    for (size_t i = 0, n = map.pixel_count(); i < n; ++i)
      s += 0.2126f * p[3 * i] + 0.7152f * p[3 * i + 1] + 0.0722f * p[3 * i + 2];
    benchmark::DoNotOptimize(s);
  }
}

void BM_Prepare(benchmark::State& state, Method method, Layout layout) {
  const EnvMap& map = scene_map(layout);
  auto sampler = make_sampler(method);
  sampler->prepare(map);  // first frame builds the geometry caches
  RatioTimer ratio(state, map);
  for (auto _ : state) sampler->prepare(map);
}

// q2tree's prepare bins the map on every core (sampling/q2tree_sums.h); the floor is one
// core's read, so its figure on one core is reported beside it.
void BM_PrepareOneThread(benchmark::State& state, Method method, Layout layout) {
  const EnvMap& map = scene_map(layout);
  auto sampler = make_sampler(method);
  tbb::task_arena one(1);
  one.execute([&] { sampler->prepare(map); });
  RatioTimer ratio(state, map);
  for (auto _ : state) one.execute([&] { sampler->prepare(map); });
}

// The same two with the map out of every cache before each call (issue 23's method, for a
// live frame that has just been unwrapped elsewhere): bench/evict_caches.h. The sampler's own
// buffers stay as the previous frame left them, as they do in a live stream. No x_read: the
// ratio timer would count the evictions.
void evict_map(benchmark::State& state, const EnvMap& map) {
  state.PauseTiming();
  lp::bench::evict_caches({{map.rgb.data(), map.rgb.size() * sizeof(float)}});
  state.ResumeTiming();
}

void BM_PlainReadCold(benchmark::State& state, Layout layout) {
  if (!lp::bench::kCanEvictCaches) return state.SkipWithError("no cache eviction on this CPU");
  const EnvMap& map = scene_map(layout);
  for (auto _ : state) {
    evict_map(state, map);
    float s = 0;
    const float* p = map.rgb.data();
    for (size_t i = 0, n = map.pixel_count(); i < n; ++i)
      s += 0.2126f * p[3 * i] + 0.7152f * p[3 * i + 1] + 0.0722f * p[3 * i + 2];
    benchmark::DoNotOptimize(s);
  }
}

void BM_PrepareCold(benchmark::State& state, Method method, Layout layout) {
  if (!lp::bench::kCanEvictCaches) return state.SkipWithError("no cache eviction on this CPU");
  const EnvMap& map = scene_map(layout);
  auto sampler = make_sampler(method);
  sampler->prepare(map);
  for (auto _ : state) {
    evict_map(state, map);
    sampler->prepare(map);
  }
}

void BM_Place(benchmark::State& state, Method method, Layout layout) {
  const EnvMap& map = scene_map(layout);
  auto sampler = make_sampler(method);
  sampler->prepare(map);
  const int n = int(state.range(0));
  for (auto _ : state) benchmark::DoNotOptimize(sampler->place(n));
}

void BM_PrepareAndPlace(benchmark::State& state, Method method, Layout layout) {
  const EnvMap& map = scene_map(layout);
  auto sampler = make_sampler(method);
  const int n = int(state.range(0));
  sampler->prepare(map);
  RatioTimer ratio(state, map);
  for (auto _ : state) {
    sampler->prepare(map);
    benchmark::DoNotOptimize(sampler->place(n));
  }
}

// The live chain's other per-frame work on the same maps: the SH9 every list carries
// (live/pipeline.h) and the preview's tone statistics (core/temporal_tonemap.h).
void BM_ProjectSh9(benchmark::State& state, Layout layout) {
  const EnvMap& map = scene_map(layout);
  RatioTimer ratio(state, map);
  for (auto _ : state) benchmark::DoNotOptimize(project_sh9(map));
}

void BM_ToneParameters(benchmark::State& state, Layout layout) {
  const EnvMap& map = scene_map(layout);
  RatioTimer ratio(state, map);
  for (auto _ : state) benchmark::DoNotOptimize(frame_tone_parameters(image_view(map)));
}

// The accuracy yardstick's reference (core/accuracy.h) per set of measures: `diffuse` is what
// eval temporal integrates per frame, `report` adds the glossy lobes s = 10, 100 (what
// `sample` reports), `full` the 64 shadowing caps too (eval sampling).
void BM_AccuracyReference(benchmark::State& state, Layout layout, int measures) {
  const EnvMap& map = scene_map(layout);
  AccuracyOptions options;
  options.shadowed = measures == 2;
  if (measures == 0) options.glossy_exponents.clear();
  RatioTimer ratio(state, map);
  for (auto _ : state) benchmark::DoNotOptimize(make_accuracy_reference(map, options).diffuse.data());
}

// Named in the stage groups of bench/stages_bench.cpp: the plain read is the floor of
// every method's prepare and of the accuracy reference.
int register_all() {
  for (Layout layout : {Layout::Hemisphere, Layout::LatLong}) {
    const std::string size = layout == Layout::Hemisphere ? "hemisphere360x90" : "latlong1024x512";
    const std::string prepare = "sampling/prepare_" + size + "/";
    benchmark::RegisterBenchmark((prepare + "floor").c_str(), BM_PlainRead, layout)->Unit(benchmark::kMicrosecond);
    const std::string prepare_cold = "sampling/prepare_" + size + "_caches_evicted/";
    benchmark::RegisterBenchmark((prepare_cold + "floor").c_str(), BM_PlainReadCold, layout)->Unit(benchmark::kMicrosecond);
    benchmark::RegisterBenchmark(("sampling/sh9_" + size + "/ours").c_str(), BM_ProjectSh9, layout)
        ->Unit(benchmark::kMicrosecond);
    benchmark::RegisterBenchmark(("sampling/tone_parameters_" + size + "/ours").c_str(), BM_ToneParameters, layout)
        ->Unit(benchmark::kMicrosecond);
    const std::string reference = "sampling/accuracy_reference_" + size + "/";
    benchmark::RegisterBenchmark((reference + "floor").c_str(), BM_PlainRead, layout)->Unit(benchmark::kMillisecond);
    const char* measures[] = {"ours:diffuse", "ours:report", "ours:full"};
    for (int m = 0; m < 3; ++m)
      benchmark::RegisterBenchmark((reference + measures[m]).c_str(), BM_AccuracyReference, layout, m)
          ->Unit(benchmark::kMillisecond)
          ->UseRealTime();
    for (Method m : all_methods()) {
      const std::string method(to_string(m));
      benchmark::RegisterBenchmark((prepare + "ours:" + method).c_str(), BM_Prepare, m, layout)
          ->Unit(benchmark::kMicrosecond);
      benchmark::RegisterBenchmark((prepare_cold + "ours:" + method).c_str(), BM_PrepareCold, m, layout)
          ->Unit(benchmark::kMicrosecond);
      if (m == Method::Q2Tree)
        benchmark::RegisterBenchmark((prepare + "ours:" + method + ", 1 thread").c_str(), BM_PrepareOneThread, m,
                                     layout)
            ->Unit(benchmark::kMicrosecond);
      benchmark::RegisterBenchmark(("sampling/place_" + size + "/ours:" + method).c_str(), BM_Place, m, layout)
          ->Arg(300)->Arg(1000)->Unit(benchmark::kMicrosecond);
      benchmark::RegisterBenchmark(("sampling/prepare_and_place_" + size + "/ours:" + method).c_str(),
                                   BM_PrepareAndPlace, m, layout)
          ->Arg(300)->Arg(1000)->Unit(benchmark::kMicrosecond);
    }
  }
  return 0;
}
const int registered = register_all();

}  // namespace
