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

#include "probe/fisheye.h"
#include "probe/remap.h"

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

void set_counters(benchmark::State& state) {
  state.counters["MPix_s"] =
      benchmark::Counter(double(kOutW) * kOutH / 1e6, benchmark::Counter::kIsIterationInvariantRate);
}

void BM_Remap_Floor(benchmark::State& state) {
  const int threads = int(state.range(0));
  const RgbImage& in = frame();
  std::vector<float> out(size_t(kOutW) * kOutH * 3);
  tbb::task_arena arena(threads);
  const size_t in_n = in.rgb.size(), out_n = out.size();
  for (auto _ : state) {
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
BENCHMARK(BM_Remap_Floor)->Name("probe/unwrap_1280x960_to_1024x512/floor")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

// kSimd: the vector kernel (RemapOptions::simd); false: the scalar loop it is tested against.
template <bool kSimd>
void BM_Remap_Compiled(benchmark::State& state) {
  const CompiledRemap c = compile_remap(table(), kInW, kInH);
  RgbImage out;
  RemapOptions o;
  o.threads = int(state.range(0));
  o.simd = kSimd;
  for (auto _ : state) {
    apply_remap(frame(), c, &out, o);
    benchmark::DoNotOptimize(out.rgb.data());
  }
  set_counters(state);
}
BENCHMARK(BM_Remap_Compiled<true>)->Name("probe/unwrap_1280x960_to_1024x512/ours")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Remap_Compiled<false>)->Name("probe/unwrap_1280x960_to_1024x512/ours:scalar loop")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_Remap_OpenCvFloatMaps(benchmark::State& state) {
  cv::setNumThreads(int(state.range(0)));
  cv::Mat src(kInH, kInW, CV_32FC3, const_cast<float*>(frame().rgb.data()));
  cv::Mat mx(kOutH, kOutW, CV_32FC1), my(kOutH, kOutW, CV_32FC1);
  for (int i = 0; i < kOutW * kOutH; ++i) {  // OpenCV: pixel centres at integers
    mx.at<float>(i / kOutW, i % kOutW) = std::isnan(table().src_x[i]) ? -10.0f : table().src_x[i] - 0.5f;
    my.at<float>(i / kOutW, i % kOutW) = std::isnan(table().src_y[i]) ? -10.0f : table().src_y[i] - 0.5f;
  }
  cv::Mat dst;
  for (auto _ : state) {
    cv::remap(src, dst, mx, my, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    benchmark::DoNotOptimize(dst.data);
  }
  set_counters(state);
  cv::setNumThreads(-1);
}
BENCHMARK(BM_Remap_OpenCvFloatMaps)->Name("probe/unwrap_1280x960_to_1024x512/peer:cv::remap")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_Remap_OpenCvFixedPointMaps(benchmark::State& state) {
  cv::setNumThreads(int(state.range(0)));
  cv::Mat src(kInH, kInW, CV_32FC3, const_cast<float*>(frame().rgb.data()));
  cv::Mat mx(kOutH, kOutW, CV_32FC1), my(kOutH, kOutW, CV_32FC1);
  for (int i = 0; i < kOutW * kOutH; ++i) {
    mx.at<float>(i / kOutW, i % kOutW) = std::isnan(table().src_x[i]) ? -10.0f : table().src_x[i] - 0.5f;
    my.at<float>(i / kOutW, i % kOutW) = std::isnan(table().src_y[i]) ? -10.0f : table().src_y[i] - 0.5f;
  }
  cv::Mat m1, m2, dst;
  cv::convertMaps(mx, my, m1, m2, CV_16SC2);
  for (auto _ : state) {
    cv::remap(src, dst, m1, m2, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    benchmark::DoNotOptimize(dst.data);
  }
  set_counters(state);
  cv::setNumThreads(-1);
}
BENCHMARK(BM_Remap_OpenCvFixedPointMaps)->Name("probe/unwrap_1280x960_to_1024x512/peer:cv::remap 16-bit maps")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

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

}  // namespace
