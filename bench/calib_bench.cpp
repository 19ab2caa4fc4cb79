// Board detection per image over the real calibration sets (calib/board_detect.h).
// Each benchmark detects every image of one set per iteration; counters report the recall
// and the CPU time per image (mean and worst). Sets missing from ../shared/data are skipped.
// Also the Kannala-Brandt unprojection of a pixel grid (calib/camera_model.h), beside
// cv::fisheye::undistortPoints on the same pixels: every projection difference of the
// selection unprojects such a grid twice.
#include <benchmark/benchmark.h>
#include <opencv2/calib3d.hpp>

#include <algorithm>
#include <ctime>
#include <opencv2/core.hpp>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "calib/board_detect.h"
#include "calib/camera_model.h"
#include "core/image_io.h"

namespace fs = std::filesystem;

namespace {

double thread_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

std::string shared_data() {
  if (const char* env = std::getenv("LIGHTPROBE_SHARED_DATA")) return env;
  for (const char* candidate : {"../shared/data", "../../shared/data", "/work/shared/data"})
    if (fs::exists(candidate)) return candidate;
  return "";
}

std::vector<lp::CameraImage> load(const std::string& dir) {
  std::vector<std::string> paths;
  if (fs::exists(dir))
    for (const auto& e : fs::directory_iterator(dir))
      if (e.path().extension() == ".jpg") paths.push_back(e.path().string());
  std::sort(paths.begin(), paths.end());
  std::vector<lp::CameraImage> images;
  for (const auto& p : paths) images.push_back(lp::read_camera_image(p));
  return images;
}

void detect_set(benchmark::State& state, const std::string& subdir, lp::BoardSpec board, bool classic) {
  const auto images = load(shared_data() + "/" + subdir);
  if (images.empty()) {
    state.SkipWithError(("no images in " + subdir).c_str());
    return;
  }
  lp::DetectOptions options;
  options.classic = classic;
  // Per image: this thread's CPU time with one OpenCV thread, so that the numbers stay
  // comparable on a machine shared with other jobs (wall time is reported too).
  cv::setNumThreads(1);
  int found = 0;
  double worst_s = 0, total_s = 0;
  for (auto _ : state) {
    found = 0;
    for (const auto& image : images) {
      const double t0 = thread_cpu_seconds();
      const lp::BoardDetection d = lp::detect_board(image, board, options);
      const double t = thread_cpu_seconds() - t0;
      found += d.found;
      total_s += t;
      worst_s = std::max(worst_s, t);
    }
  }
  cv::setNumThreads(-1);
  state.counters["found"] = found;
  state.counters["cpu_ms_mean"] = 1e3 * total_s / (double(images.size()) * double(state.iterations()));
  state.counters["cpu_ms_worst"] = 1e3 * worst_s;
  state.counters["images"] = static_cast<double>(images.size());
  state.counters["s_per_image"] = benchmark::Counter(
      static_cast<double>(images.size()), benchmark::Counter::kIsIterationInvariantRate |
                                              benchmark::Counter::kInvert);
}

void register_all() {
  struct Set {
    const char* name;
    const char* dir;
    lp::BoardSpec board;
  };
  const Set sets[] = {
      {"opencv_stereo_9x6", "calib-opencv-stereo-9x6", {9, 6, 25}},
      {"ocamcalib_fisheye1", "calib-ocamcalib-fisheye1", {6, 8, 32.5}},
      {"Fisheye190deg", "calib-ocamcalib-omni-samples/Fisheye190deg", {6, 7, 30}},
      {"VMRImage", "calib-ocamcalib-omni-samples/VMRImage", {6, 7, 30}},
      {"Ladybug", "calib-ocamcalib-omni-samples/Ladybug", {5, 8, 30}},
      {"KaidanOmni", "calib-ocamcalib-omni-samples/KaidanOmni", {7, 11, 30}},
      {"MiniOmni", "calib-ocamcalib-omni-samples/MiniOmni", {7, 11, 30}},
  };
  for (const Set& s : sets) {
    for (bool classic : {true, false}) {
      // Stage groups (bench/stages_bench.cpp): the cascade is what calib runs.
      const std::string name = std::string("calib/detect_all_") + s.name + (classic ? "/ours" : "/ours:sb only");
      const std::string dir = s.dir;
      const lp::BoardSpec board = s.board;
      benchmark::RegisterBenchmark(name.c_str(), [dir, board, classic](benchmark::State& st) {
        detect_set(st, dir, board, classic);
      })->Unit(benchmark::kMillisecond)->Iterations(1);
    }
  }
}

}  // namespace

// The 190 deg lens of the tests (kb190); test_cameras.h's real sets need this macro.
#define LIGHTPROBE_SHARED_DATA shared_data()
#include "tests/calib/test_cameras.h"
#undef LIGHTPROBE_SHARED_DATA

namespace {

// The pixels of an 8 px grid (as the selection's projection differences sample a 1280x960
// image) whose ray is within 85 deg of the axis under the 190 deg lens of the tests: where
// cv::fisheye, which unprojects onto the plane z = 1, has an answer too.
std::vector<lp::Pixel> kb_grid(const lp::CameraModel& cam) {
  std::vector<lp::Pixel> px;
  for (int y = 4; y < cam.height; y += 8)
    for (int x = 4; x < cam.width; x += 8)
      if (const auto r = lp::unproject(cam, {double(x), double(y)}); r && r->z > std::cos(85 * M_PI / 180))
        px.push_back({double(x), double(y)});
  return px;
}

void BM_UnprojectKannalaBrandt(benchmark::State& state) {
  const lp::CameraModel cam = lp::calib_test::kb190();
  const std::vector<lp::Pixel> px = kb_grid(cam);
  double sum = 0;
  for (auto _ : state)
    for (const lp::Pixel& q : px) sum += lp::unproject(cam, q)->z;
  benchmark::DoNotOptimize(sum);
  state.counters["pixels"] = double(px.size());
}

void BM_UnprojectKannalaBrandtOpenCv(benchmark::State& state) {
  const lp::CameraModel cam = lp::calib_test::kb190();
  const std::vector<lp::Pixel> px = kb_grid(cam);
  const auto& p = cam.intrinsics;
  const cv::Matx33d K(p[0], 0, p[2], 0, p[1], p[3], 0, 0, 1);
  const cv::Vec4d D(p[4], p[5], p[6], p[7]);
  std::vector<cv::Point2d> in, out;
  for (const lp::Pixel& q : px) in.push_back({q.x, q.y});
  for (auto _ : state) cv::fisheye::undistortPoints(in, out, K, D);
  benchmark::DoNotOptimize(out.data());
  state.counters["pixels"] = double(px.size());
}

BENCHMARK(BM_UnprojectKannalaBrandt)->Name("calib/unproject_kannala_brandt_grid/ours")->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_UnprojectKannalaBrandtOpenCv)
    ->Name("calib/unproject_kannala_brandt_grid/peer:cv::fisheye::undistortPoints")
    ->Unit(benchmark::kMicrosecond);

const int registered = (register_all(), 0);

}  // namespace
