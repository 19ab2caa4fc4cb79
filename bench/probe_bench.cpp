// Remap engine speed (issue 5): a 1280x960 float RGB fisheye frame -> 1024x512 latlong.
// The fisheye is equidistant over the whole sphere (fov 360) so that every output pixel
// is interpolated (the worst case; a 190-degree lens leaves ~half the map invalid and
// cheap). Compared with cv::remap (CV_32FC3 source, CV_32FC1 maps; and the same maps
// converted to CV_16SC2 fixed point) and with the memory floor: one pass reading the
// input and writing the output. Arg = threads (TBB arena / cv::setNumThreads).
// Counter MPix_s = output megapixels per second.
//   build/bench/lightprobe_bench --benchmark_filter=^probe/ --benchmark_counters_tabular=true
// (names: the stage groups of bench/stages_bench.cpp; the last number is the thread count)
#include <benchmark/benchmark.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <numeric>
#include <random>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "bench/evict_caches.h"
#include "eval/synthetic_scene.h"
#include "probe/fisheye.h"
#include "probe/mirror_ball.h"
#include "probe/remap.h"
#include "probe/synthetic_probe.h"

namespace {

using namespace lp;

constexpr int kInW = 1280, kInH = 960, kOutW = 1024, kOutH = 512;

const RgbImage& frame() {
  static RgbImage im = [] {
    RgbImage f;
    f.width = kInW;
    f.height = kInH;
    f.rgb.resize(size_t(kInW) * kInH * 3);
    std::mt19937 rng(1);
    std::uniform_real_distribution<float> u(0.0f, 4.0f);
    for (float& v : f.rgb) v = u(rng);
    return f;
  }();
  return im;
}

const RemapTable& table() {
  static RemapTable t = fisheye_remap(equidistant_fisheye(kInW, kInH, 360), Layout::LatLong, kOutW, kOutH);
  return t;
}

// kCold: every buffer the call reads or writes (frame, table or maps, output) leaves the
// caches before each timed call (bench/evict_caches.h), as issue 23 measures; the row is
// skipped where that cannot be done.
template <bool kCold>
bool cold_supported(benchmark::State& state) {
  if (kCold && !lp::bench::kCanEvictCaches) {
    state.SkipWithError("no cache eviction on this CPU");
    return false;
  }
  return true;
}

template <bool kCold>
void evict_between_calls(benchmark::State& state, std::initializer_list<std::pair<const void*, size_t>> buffers) {
  if (!kCold) return;
  state.PauseTiming();
  lp::bench::evict_caches(buffers);
  state.ResumeTiming();
}

size_t mat_bytes(const cv::Mat& m) { return m.total() * m.elemSize(); }

void set_counters(benchmark::State& state) {
  state.counters["MPix_s"] =
      benchmark::Counter(double(kOutW) * kOutH / 1e6, benchmark::Counter::kIsIterationInvariantRate);
}

template <bool kCold = false>
void BM_Remap_Floor(benchmark::State& state) {
  if (!cold_supported<kCold>(state)) return;
  const int threads = int(state.range(0));
  const RgbImage& in = frame();
  std::vector<float> out(size_t(kOutW) * kOutH * 3);
  tbb::task_arena arena(threads);
  const size_t in_n = in.rgb.size(), out_n = out.size();
  for (auto _ : state) {
    evict_between_calls<kCold>(state, {{in.rgb.data(), in_n * sizeof(float)}, {out.data(), out_n * sizeof(float)}});
    arena.execute([&] {
      // Read every input float once and write every output float once, split in chunks.
      tbb::parallel_for(tbb::blocked_range<int>(0, 64), [&](const tbb::blocked_range<int>& r) {
        for (int c = r.begin(); c < r.end(); ++c) {
          const size_t a = in_n * c / 64, b = in_n * (c + 1) / 64;
          float s = 0;
          for (size_t i = a; i < b; ++i) s += in.rgb[i];
          const size_t oa = out_n * c / 64, ob = out_n * (c + 1) / 64;
          std::fill(out.begin() + oa, out.begin() + ob, s);
        }
      });
    });
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  set_counters(state);
}
BENCHMARK(BM_Remap_Floor<>)->Name("probe/unwrap_1280x960_to_1024x512/floor")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

// kSimd: the vector kernel (RemapOptions::simd); false: the scalar loop it is tested against.
template <bool kSimd, bool kCold = false>
void BM_Remap_Compiled(benchmark::State& state) {
  if (!cold_supported<kCold>(state)) return;
  const CompiledRemap c = compile_remap(table(), kInW, kInH);
  RgbImage out;
  RemapOptions o;
  o.threads = int(state.range(0));
  o.simd = kSimd;
  if (kCold) apply_remap(frame(), c, &out, o);  // the output exists before the first eviction
  for (auto _ : state) {
    evict_between_calls<kCold>(state, {{frame().rgb.data(), frame().rgb.size() * sizeof(float)},
                                       {c.taps.data(), c.taps.size() * sizeof(CompiledRemap::Tap)},
                                       {out.rgb.data(), out.rgb.size() * sizeof(float)}});
    apply_remap(frame(), c, &out, o);
    benchmark::DoNotOptimize(out.rgb.data());
  }
  set_counters(state);
}
BENCHMARK(BM_Remap_Compiled<true>)->Name("probe/unwrap_1280x960_to_1024x512/ours")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Remap_Compiled<false>)->Name("probe/unwrap_1280x960_to_1024x512/ours:scalar loop")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

template <bool kCold = false>
void BM_Remap_OpenCvFloatMaps(benchmark::State& state) {
  if (!cold_supported<kCold>(state)) return;
  cv::setNumThreads(int(state.range(0)));
  cv::Mat src(kInH, kInW, CV_32FC3, const_cast<float*>(frame().rgb.data()));
  cv::Mat mx(kOutH, kOutW, CV_32FC1), my(kOutH, kOutW, CV_32FC1);
  for (int i = 0; i < kOutW * kOutH; ++i) {  // OpenCV: pixel centres at integers
    mx.at<float>(i / kOutW, i % kOutW) = std::isnan(table().src_x[i]) ? -10.0f : table().src_x[i] - 0.5f;
    my.at<float>(i / kOutW, i % kOutW) = std::isnan(table().src_y[i]) ? -10.0f : table().src_y[i] - 0.5f;
  }
  cv::Mat dst;
  if (kCold) cv::remap(src, dst, mx, my, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  for (auto _ : state) {
    evict_between_calls<kCold>(state, {{src.data, mat_bytes(src)}, {mx.data, mat_bytes(mx)}, {my.data, mat_bytes(my)},
                                       {dst.data, mat_bytes(dst)}});
    cv::remap(src, dst, mx, my, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    benchmark::DoNotOptimize(dst.data);
  }
  set_counters(state);
  cv::setNumThreads(-1);
}
BENCHMARK(BM_Remap_OpenCvFloatMaps<>)->Name("probe/unwrap_1280x960_to_1024x512/peer:cv::remap")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

template <bool kCold = false>
void BM_Remap_OpenCvFixedPointMaps(benchmark::State& state) {
  if (!cold_supported<kCold>(state)) return;
  cv::setNumThreads(int(state.range(0)));
  cv::Mat src(kInH, kInW, CV_32FC3, const_cast<float*>(frame().rgb.data()));
  cv::Mat mx(kOutH, kOutW, CV_32FC1), my(kOutH, kOutW, CV_32FC1);
  for (int i = 0; i < kOutW * kOutH; ++i) {
    mx.at<float>(i / kOutW, i % kOutW) = std::isnan(table().src_x[i]) ? -10.0f : table().src_x[i] - 0.5f;
    my.at<float>(i / kOutW, i % kOutW) = std::isnan(table().src_y[i]) ? -10.0f : table().src_y[i] - 0.5f;
  }
  cv::Mat m1, m2, dst;
  cv::convertMaps(mx, my, m1, m2, CV_16SC2);
  if (kCold) cv::remap(src, dst, m1, m2, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  for (auto _ : state) {
    evict_between_calls<kCold>(state, {{src.data, mat_bytes(src)}, {m1.data, mat_bytes(m1)}, {m2.data, mat_bytes(m2)},
                                       {dst.data, mat_bytes(dst)}});
    cv::remap(src, dst, m1, m2, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    benchmark::DoNotOptimize(dst.data);
  }
  set_counters(state);
  cv::setNumThreads(-1);
}
BENCHMARK(BM_Remap_OpenCvFixedPointMaps<>)->Name("probe/unwrap_1280x960_to_1024x512/peer:cv::remap 16-bit maps")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

// The same with the caches evicted before each call (issue 23's method).
BENCHMARK(BM_Remap_Floor<true>)->Name("probe/unwrap_1280x960_to_1024x512_caches_evicted/floor")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Remap_Compiled<true, true>)->Name("probe/unwrap_1280x960_to_1024x512_caches_evicted/ours")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Remap_OpenCvFloatMaps<true>)->Name("probe/unwrap_1280x960_to_1024x512_caches_evicted/peer:cv::remap")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Remap_OpenCvFixedPointMaps<true>)->Name("probe/unwrap_1280x960_to_1024x512_caches_evicted/peer:cv::remap 16-bit maps")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

// Once per geometry: the fisheye table and its compilation.
void BM_Remap_BuildFisheyeTable(benchmark::State& state) {
  const FisheyeModel m = equidistant_fisheye(kInW, kInH, 360);
  for (auto _ : state) benchmark::DoNotOptimize(fisheye_remap(m, Layout::LatLong, kOutW, kOutH).src_x.data());
}
BENCHMARK(BM_Remap_BuildFisheyeTable)->Name("probe/unwrap_table_build/ours")->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_Remap_Compile(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(compile_remap(table(), kInW, kInH).taps.data());
}
BENCHMARK(BM_Remap_Compile)->Name("probe/unwrap_table_compile/ours")->Unit(benchmark::kMillisecond)->UseRealTime();

// Finding the ball in one 1920 x 1080 frame (R 250, the synthetic scene, 1 % noise): the
// whole search, and the search a sequence's next frame gets, from the last frame's ball 1.5 px
// away (UnwrapSequenceOptions::seed_from_previous; docs/probes.md "Sequences"). No floor or
// peer: OpenCV has no mirror-ball finder (HoughCircles finds the ball's reflections too).
// glibc's default heap, as any library caller has it (`probe unwrap` keeps the heap between a
// sequence's frames, core/heap_tuning.h, which would change every later benchmark's process).
const RgbImage& ball_frame() {
  static RgbImage im = [] {
    const EnvMap world = render_scene(describe_scene(), Layout::LatLong, 512, 256);
    RenderBallOptions o;
    o.noise_relative = 0.01;
    return render_mirror_ball(world, {960.3, 540.6, 250}, MirrorBallCamera{}, 1920, 1080, o);
  }();
  return im;
}

template <bool kSeeded>
void BM_FindBall(benchmark::State& state) {
  FindBallOptions o;
  if (kSeeded) {
    o.initial_guess = BallInImage{961.4, 539.5, 250.2};
    o.initial_guess_reach_px = 8;
  }
  for (auto _ : state) benchmark::DoNotOptimize(find_ball(ball_frame(), o).cx);
}
BENCHMARK(BM_FindBall<false>)->Name("probe/find_ball_1920x1080/ours")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_FindBall<true>)->Name("probe/find_ball_1920x1080/ours:seeded from the last frame")->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
