// The stage groups docs/performance.md is made from (scripts/performance.sh), for the stages
// whose benchmarks live nowhere else: `hdr` (the merge), `startup` (a whole command) and the
// whole commands a user waits for (`sampling/sample_command`, `eval/temporal_command`).
// Names follow the table's convention, <stage>/<figure>/<role>, role one of
//   ours[:variant]   what lightprobe runs
//   floor            the least any implementation must do on the same bytes (a read of the
//                    inputs and a write of the output; a process that does nothing)
//   peer:<name>      another library's answer to the same question, in the same process
// so that every figure is printed beside its floor and its peer, measured in one run.
//   build/bench/lightprobe_bench --benchmark_filter='^(hdr|startup)/'
#include <benchmark/benchmark.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <fcntl.h>
#include <spawn.h>
#include <unistd.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "bench/evict_caches.h"
#include "hdr/bracket.h"
#include "hdr/merge.h"
#include "hdr/opencv_peer.h"
#include "hdr/response.h"

extern char** environ;

namespace {

using namespace lp;

constexpr int kW = 1280, kH = 960;
const std::vector<double> kExposures = {0.0005, 0.004, 0.032};

// A sky-like radiance ramp over four decades, seen at three exposures by an 8-bit sensor.
const Bracket& bracket() {
  static const Bracket b = [] {
    Bracket out;
    out.exposure_seconds = kExposures;
    for (double t : kExposures) {
      RgbImage f;
      f.width = kW;
      f.height = kH;
      f.rgb.resize(size_t(kW) * kH * 3);
      for (int y = 0; y < kH; ++y)
        for (int x = 0; x < kW; ++x) {
          const double radiance = std::pow(10.0, 4.0 * x / kW) * (1.0 + 0.2 * (y % 7));
          for (int c = 0; c < 3; ++c) {
            const double v = std::min(1.0, radiance * t * (0.8 + 0.2 * c) / 40.0);
            f.rgb[(size_t(y) * kW + x) * 3 + c] = float(std::round(v * 255) / 255);
          }
        }
      out.frames.push_back(std::move(f));
    }
    return out;
  }();
  return b;
}

// The same bracket as read_bracket keeps an 8-bit one: with its codes (Bracket::codes).
const Bracket& bracket_8bit() {
  static const Bracket b = [] {
    Bracket out = bracket();
    keep_8bit_codes(out);
    return out;
  }();
  return b;
}

// kCold: before each timed call, the frames' floats, their 8-bit codes and the output leave
// every cache (bench/evict_caches.h), as issue 23 measures.
void evict_bracket(const Bracket& b, const void* out, size_t out_bytes) {
  for (size_t k = 0; k < b.frames.size(); ++k) {
    lp::bench::evict_caches({{b.frames[k].rgb.data(), b.frames[k].rgb.size() * sizeof(float)}});
    if (k < b.codes.size()) lp::bench::evict_caches({{b.codes[k].data(), b.codes[k].size()}});
  }
  lp::bench::evict_caches({{out, out_bytes}});
}

// The caches emptied between timed calls, or the row skipped where that cannot be done.
template <bool kCold>
bool cold_supported(benchmark::State& state) {
  if (kCold && !lp::bench::kCanEvictCaches) {
    state.SkipWithError("no cache eviction on this CPU");
    return false;
  }
  return true;
}

void set_pixels(benchmark::State& state) {
  state.counters["MPix_s"] = benchmark::Counter(double(kW) * kH / 1e6, benchmark::Counter::kIsIterationInvariantRate);
}

// kSimd: the vector kernel (MergeOptions::simd); false: the scalar loop it is tested against.
// Into one output image reused from call to call, as the floor writes one buffer (a stream
// merges so); kFreshOutput: a new image each call (merge_bracket's returning form).
// kThreads 1: the whole merge on the calling thread, whose CPU time is little disturbed by
// other processes on a shared machine (the 2-thread real time waits for a core).
// k8Bit: the frames' 8-bit codes are read instead of their floats (an 8-bit bracket).
// kPerChannel: a response whose three channels are different curves (a white balance in the
// response, as a recovered one has), which the 8-bit kernel reads channel by channel; the
// linear default is one curve for R, G and B, read as interleaved codes (merge_kernel.h).
CameraResponse per_channel_response() {
  CameraResponse r = linear_response(256);
  r.linear = false;
  for (int c = 1; c < 3; ++c)
    for (float& g : r.log_exposure[size_t(c)]) g += float(std::log(1.0 + 0.05 * c));
  return r;
}

template <bool kSimd, bool kFreshOutput = false, int kThreads = 2, bool k8Bit = false, bool kCold = false,
          bool kPerChannel = false>
void BM_MergeOurs(benchmark::State& state) {
  if (!cold_supported<kCold>(state)) return;
  const CameraResponse response = kPerChannel ? per_channel_response() : linear_response(256);
  MergeOptions o;
  o.threads = kThreads;
  o.simd = kSimd;
  const Bracket& source = k8Bit ? bracket_8bit() : bracket();
  const BracketView b = bracket_view(source);  // made once, outside the timing
  RgbImage out;
  if (kCold) merge_bracket(b, response, o, &out);  // the output exists before the first eviction
  for (auto _ : state) {
    if (kCold) {
      state.PauseTiming();
      evict_bracket(source, out.rgb.data(), out.rgb.size() * sizeof(float));
      state.ResumeTiming();
    }
    if (kFreshOutput)
      benchmark::DoNotOptimize(merge_bracket(b, response, o).rgb.data());
    else
      merge_bracket(b, response, o, &out);
    benchmark::DoNotOptimize(out.rgb.data());
    benchmark::ClobberMemory();
  }
  set_pixels(state);
}

// A real scene's 8-bit bracket (Debevec's Memorial, 3 of its 16 frames, 512x768 with a black
// border and clipped windows), one thread: how the kernel fares where a block's codes are not a
// smooth ramp. Skipped without the shared data (LIGHTPROBE_SHARED_DATA or ../shared/data).
void BM_MergeMemorial(benchmark::State& state) {
  std::string dir;
  if (const char* env = std::getenv("LIGHTPROBE_SHARED_DATA")) dir = env;
  for (const char* candidate : {"../shared/data", "../../shared/data", "/work/shared/data"})
    if (dir.empty() && std::filesystem::exists(candidate)) dir = candidate;
  dir += "/hdr-memorial-debevec/";
  if (!std::filesystem::exists(dir + "memorial0064.png")) {
    state.SkipWithError(("no Memorial bracket in " + dir).c_str());
    return;
  }
  const Bracket b = read_bracket({dir + "memorial0064.png", dir + "memorial0066.png", dir + "memorial0068.png"},
                                 std::vector<double>{4.0, 1.0, 0.25});
  const BracketView view = bracket_view(b);
  const CameraResponse response = linear_response(256);
  MergeOptions o;
  o.threads = 1;
  RgbImage out;
  for (auto _ : state) {
    merge_bracket(view, response, o, &out);
    benchmark::DoNotOptimize(out.rgb.data());
    benchmark::ClobberMemory();
  }
  state.counters["MPix_s"] = benchmark::Counter(double(b.width()) * b.height() / 1e6, benchmark::Counter::kIsIterationInvariantRate);
}

// Read the three frames once and write one float RGB image, on the merge's two threads:
// the bytes a merge must move.
template <bool kCold = false>
void BM_MergeFloor(benchmark::State& state) {
  if (!cold_supported<kCold>(state)) return;
  const Bracket& b = bracket();
  std::vector<float> out(b.frames[0].rgb.size());
  const float* f0 = b.frames[0].rgb.data();
  const float* f1 = b.frames[1].rgb.data();
  const float* f2 = b.frames[2].rgb.data();
  tbb::task_arena arena(2);
  for (auto _ : state) {
    if (kCold) {
      state.PauseTiming();
      evict_bracket(b, out.data(), out.size() * sizeof(float));
      state.ResumeTiming();
    }
    arena.execute([&] {
      tbb::parallel_for(tbb::blocked_range<size_t>(0, out.size(), 1 << 16), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i < r.end(); ++i) out[i] = f0[i] + f1[i] + f2[i];
      });
    });
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  set_pixels(state);
}

// The same with the three frames' 8-bit codes (3.7 MB each instead of 14.7): the floor of a
// merge of an 8-bit bracket, which is what issue 23's aim reads.
template <bool kCold = false>
void BM_MergeFloor8Bit(benchmark::State& state) {
  if (!cold_supported<kCold>(state)) return;
  const Bracket& b = bracket_8bit();
  std::vector<float> out(b.frames[0].rgb.size());
  const uint8_t* f0 = b.codes[0].data();
  const uint8_t* f1 = b.codes[1].data();
  const uint8_t* f2 = b.codes[2].data();
  tbb::task_arena arena(2);
  for (auto _ : state) {
    if (kCold) {
      state.PauseTiming();
      evict_bracket(b, out.data(), out.size() * sizeof(float));
      state.ResumeTiming();
    }
    arena.execute([&] {
      tbb::parallel_for(tbb::blocked_range<size_t>(0, out.size(), 1 << 16), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i < r.end(); ++i) out[i] = float(int(f0[i]) + int(f1[i]) + int(f2[i]));
      });
    });
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  set_pixels(state);
}

// cv::MergeDebevec on the same bracket (as 8-bit frames; the conversion is not timed).
template <bool kCold = false>
void BM_MergeOpenCv(benchmark::State& state) {
  if (!cold_supported<kCold>(state)) return;
  const Bracket& b = bracket();
  for (auto _ : state) {
    if (kCold) evict_bracket(b, nullptr, 0);  // manual time: only opencv_merge's own seconds count
    double seconds = 0;
    benchmark::DoNotOptimize(opencv_merge(b, OpenCvHdrMethod::Debevec, nullptr, &seconds).rgb.data());
    state.SetIterationTime(seconds);
  }
  set_pixels(state);
}

// Wall time of a whole process: `lightprobe --version` against /bin/true (the cost of a
// process that loads nothing but libc).
void spawn_and_wait(benchmark::State& state, const char* program, std::vector<std::string> args) {
  std::vector<char*> argv;
  argv.push_back(const_cast<char*>(program));
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  for (auto _ : state) {
    pid_t pid = 0;
    if (posix_spawn(&pid, program, &actions, nullptr, argv.data(), environ) != 0) {
      state.SkipWithError((std::string("cannot run ") + program).c_str());
      break;
    }
    int status = 0;
    waitpid(pid, &status, 0);
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
      state.SkipWithError((std::string(program) + " failed").c_str());
      break;
    }
  }
  posix_spawn_file_actions_destroy(&actions);
}

void BM_StartOurs(benchmark::State& state) { spawn_and_wait(state, LIGHTPROBE_EXE, {"--version"}); }
void BM_StartFloor(benchmark::State& state) { spawn_and_wait(state, "/bin/true", {}); }

// Whole commands on the shared 1024x512 Blender "sunrise" probe (LIGHTPROBE_SHARED_DATA, as
// scripts/performance.sh sets it): `sample --n 256` with its accuracy report (issue 23 aim
// <= 60 ms), and `eval temporal` with its defaults, 4 methods x 7 scenarios x 48 frames
// (aim <= 10 s). Their start is in startup/version.
std::string shared_probe(benchmark::State& state) {
  const char* data = std::getenv("LIGHTPROBE_SHARED_DATA");
  const std::string path = std::string(data ? data : "") + "/probes-blender-studiolights/sunrise.exr";
  if (!data || !std::filesystem::exists(path)) state.SkipWithError("LIGHTPROBE_SHARED_DATA has no sunrise.exr");
  return path;
}

// The report's default (the diffuse error) or, with `glossy`, also the glossy errors.
template <bool glossy>
void BM_SampleCommand(benchmark::State& state) {
  const std::string probe = shared_probe(state), out = std::filesystem::temp_directory_path() / "lightprobe_bench_lights.json";
  std::vector<std::string> args{"sample", probe, "--n", "256", "-o", out};
  if (glossy) args.push_back("--glossy-errors");
  if (!state.error_occurred()) spawn_and_wait(state, LIGHTPROBE_EXE, args);
}

void BM_EvalTemporalCommand(benchmark::State& state) {
  const std::string probe = shared_probe(state), out = std::filesystem::temp_directory_path() / "lightprobe_bench_temporal";
  if (!state.error_occurred()) spawn_and_wait(state, LIGHTPROBE_EXE, {"eval", "temporal", probe, "-o", out});
}

}  // namespace

BENCHMARK(BM_MergeOurs<true>)->Name("hdr/merge_3x1280x960/ours")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_MergeOurs<true, true>)->Name("hdr/merge_3x1280x960/ours:new output image per call")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_MergeOurs<true, false, 1>)->Name("hdr/merge_3x1280x960/ours:1 thread")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_MergeOurs<false>)->Name("hdr/merge_3x1280x960/ours:scalar loop")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_MergeOurs<true, false, 2, true>)->Name("hdr/merge_3x1280x960/ours:8-bit frames")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_MergeOurs<true, false, 1, true>)->Name("hdr/merge_3x1280x960/ours:8-bit frames, 1 thread")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_MergeOurs<true, false, 2, true, false, true>)->Name("hdr/merge_3x1280x960/ours:8-bit frames, per-channel response")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_MergeMemorial)->Name("hdr/merge_memorial_3x512x768/ours:8-bit frames, 1 thread")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_MergeFloor<>)->Name("hdr/merge_3x1280x960/floor")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_MergeFloor8Bit<>)->Name("hdr/merge_3x1280x960/floor:8-bit frames")->Unit(benchmark::kMillisecond)->UseRealTime();
// The same with the caches evicted before each call (issue 23's method; evict_caches.h).
BENCHMARK(BM_MergeOurs<true, false, 2, false, true>)->Name("hdr/merge_3x1280x960_caches_evicted/ours")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_MergeOurs<true, false, 2, true, true>)->Name("hdr/merge_3x1280x960_caches_evicted/ours:8-bit frames")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_MergeOurs<true, false, 1, true, true>)->Name("hdr/merge_3x1280x960_caches_evicted/ours:8-bit frames, 1 thread")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_MergeFloor<true>)->Name("hdr/merge_3x1280x960_caches_evicted/floor")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_MergeFloor8Bit<true>)->Name("hdr/merge_3x1280x960_caches_evicted/floor:8-bit frames")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_MergeOpenCv<true>)->Name("hdr/merge_3x1280x960_caches_evicted/peer:cv::MergeDebevec")->Unit(benchmark::kMillisecond)->UseManualTime();
BENCHMARK(BM_MergeOpenCv<>)->Name("hdr/merge_3x1280x960/peer:cv::MergeDebevec")->Unit(benchmark::kMillisecond)->UseManualTime();
BENCHMARK(BM_StartOurs)->Name("startup/version/ours")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_StartFloor)->Name("startup/version/floor")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SampleCommand<false>)->Name("sampling/sample_command_n256/ours")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SampleCommand<true>)->Name("sampling/sample_command_n256/ours:glossy errors")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_EvalTemporalCommand)->Name("eval/temporal_command_1024x512/ours")->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);
