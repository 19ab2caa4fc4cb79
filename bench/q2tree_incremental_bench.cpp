// Per-frame cost of the Q2-tree with the tree kept between frames (q2_incremental) and
// rebuilt every frame, on a sequence where little changes: the procedural scene with fresh
// 1 % noise on every pixel and a small lamp (1.5 degrees half-angle) that moves 0.5 degree
// a frame. One iteration is prepare + place(n) of the next frame; the frames play back and
// forth so that no step jumps. Counters: prepare_us and place_us split the frame,
// pairs_per_frame is the incremental repair's merge-and-split pairs.
//   build/bench/lightprobe_bench --benchmark_filter=Q2Incremental --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "eval/synthetic_scene.h"
#include "sampling/q2tree.h"
#include "sampling/sampler.h"

namespace {

using namespace lp;

constexpr int kSequenceFrames = 10;

double unit_noise(uint64_t key) {  // SplitMix64 -> [-1, 1)
  key += 0x9E3779B97F4A7C15ull;
  key = (key ^ (key >> 30)) * 0xBF58476D1CE4E5B9ull;
  key = (key ^ (key >> 27)) * 0x94D049BB133111EBull;
  key ^= key >> 31;
  return double(key >> 11) * 0x1.0p-52 - 1.0;
}

const std::vector<EnvMap>& sequence(Layout layout) {
  static std::map<Layout, std::vector<EnvMap>> cache;
  auto& frames = cache[layout];
  if (!frames.empty()) return frames;
  const auto scene = describe_scene();
  const EnvMap still = layout == Layout::Hemisphere ? render_scene(scene, layout, 360, 90)
                                                     : render_scene(scene, layout, 1024, 512);
  const double cap = std::cos(1.5 * M_PI / 180);
  for (int f = 0; f < kSequenceFrames; ++f) {
    EnvMap m = still;
    const Vec3 lamp = direction_from_angles(60 * M_PI / 180, (200 + 0.5 * f) * M_PI / 180);
    for (size_t i = 0; i < m.pixel_count(); ++i) {
      const Vec3 d = pixel_direction(m, i);
      const float boost = dot(d, lamp) > cap ? 40.0f : 0.0f;
      float* p = m.pixel(i);
      for (int c = 0; c < 3; ++c) p[c] = (p[c] + boost) * float(1 + 0.01 * unit_noise(uint64_t(f) << 40 | (3 * i + c)));
    }
    frames.push_back(std::move(m));
  }
  return frames;
}

void BM_Q2IncrementalFrame(benchmark::State& state, Layout layout, int n, bool incremental) {
  const auto& frames = sequence(layout);
  SamplerOptions options;
  options.q2_incremental = incremental;
  auto sampler = make_sampler(Method::Q2Tree, options);
  sampler->prepare(frames[0]);
  sampler->place(n);
  // 0, 1, ..., 9, 8, ..., 1, 0, 1, ...
  const int period = 2 * (kSequenceFrames - 1);
  int64_t step = 1, pairs = 0, updates = 0;
  double prepare_s = 0, place_s = 0;
  for (auto _ : state) {
    const int k = int(step++ % period);
    const EnvMap& frame = frames[size_t(k < kSequenceFrames ? k : period - k)];
    const auto t0 = std::chrono::steady_clock::now();
    sampler->prepare(frame);
    const auto t1 = std::chrono::steady_clock::now();
    auto lights = sampler->place(n);
    const auto t2 = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(lights.data());
    prepare_s += std::chrono::duration<double>(t1 - t0).count();
    place_s += std::chrono::duration<double>(t2 - t1).count();
    if (const auto ops = q2tree_last_update_operations(*sampler)) pairs += *ops, ++updates;
  }
  const double iterations = double(std::max<benchmark::IterationCount>(1, state.iterations()));
  state.counters["prepare_us"] = 1e6 * prepare_s / iterations;
  state.counters["place_us"] = 1e6 * place_s / iterations;
  state.counters["pairs_per_frame"] = updates ? double(pairs) / double(updates) : 0.0;
}

const bool registered = [] {
  struct Case {
    Layout layout;
    const char* size;
    int n;
  };
  for (const Case& c : {Case{Layout::Hemisphere, "hemisphere_360x90", 300}, Case{Layout::LatLong, "latlong_1024x512", 1000}})
    for (const bool incremental : {true, false}) {
      const std::string name = std::string("Q2IncrementalFrame/") + c.size + "/n" + std::to_string(c.n) +
                               (incremental ? "/incremental" : "/rebuild");
      benchmark::RegisterBenchmark(name.c_str(), BM_Q2IncrementalFrame, c.layout, c.n, incremental)
          ->Unit(benchmark::kMicrosecond);
    }
  return true;
}();

}  // namespace
