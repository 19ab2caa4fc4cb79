// eval sampling: time and error of every sampler at every light count, on every map
// (CONVENTIONS.md "How accuracy is measured"). Times are medians of repeated runs with the
// map already in memory, split into pre-processing (prepare) and placement (place).
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <string>
#include <vector>

#include "eval/harness.h"
#include "sampling/sampler.h"

namespace lp {

struct EvalSamplingOptions {
  // Map files; "scene" renders the procedural scene (latlong 1024x512).
  std::vector<std::string> maps;
  std::vector<Method> methods = all_methods();
  // Light counts n; a Q2-tree skips counts below its 12 base quads.
  std::vector<int> counts = {16, 32, 64, 128, 256, 512, 1024, 2048, 4096};
  // Created; receives sampling.csv, sampling.svg and, with several maps, sampling_<map>.svg.
  std::string output_dir;
  // Timing runs per point; 0: adaptive (at least 5, ~0.3 s for prepare, ~0.1 s for place).
  int repeats = 0;
  // The shadowed error (its reference: ~35 ms more per 1024x512 map).
  bool shadowed = true;
  // Lights + ambient (`sample --residual sh9`): n lights of the map's peaks + SH9 of the
  // rest, scored against n lights of the whole map alone and SH9 alone, at these n with
  // this method (empty: not measured). Written to sampling_ambient.csv / .svg.
  std::vector<int> ambient_counts = {1, 2, 4, 8, 16, 64};
  Method ambient_method = Method::MedianCut;  // pharr is noisy at small n (docs/sampling.md)
};

// One way to light at one n: "lights+sh9", "lights" or "sh9" (the last does not depend on n).
struct AmbientPoint {
  std::string map, variant;
  int n = 0;
  double diffuse = 0, glossy10 = 0, glossy100 = 0, shadowed = 0;
  double light_power_share = 0;  // lights+sh9: the lights' share of the map's luminance power
};

struct SamplingPoint {
  std::string map, method;  // map label ("median" for the medians over maps)
  int n = 0, lights = 0;
  double prepare_ms = 0, place_ms = 0;
  double diffuse = 0, glossy10 = 0, glossy100 = 0, shadowed = 0;  // relative RMS errors
};

struct EvalSamplingReport {
  std::vector<SamplingPoint> points;   // map x method x count, in that order
  std::vector<SamplingPoint> medians;  // method x count: medians over the maps
  std::vector<AmbientPoint> ambient;          // map x n x variant
  std::vector<AmbientPoint> ambient_medians;  // n x variant, medians over the maps
  size_t maps = 0;
  std::string csv_path, svg_path, ambient_csv_path, ambient_svg_path;
  // The table of medians and where the files went.
  std::string summary() const;
  // {"csv", "chart", "points": [every point], "ambient": {"csv", "chart", "points"}}.
  nlohmann::json to_json() const;
};

// InputError naming the map when a map cannot be read or sampled.
EvalSamplingReport evaluate_sampling(const EvalSamplingOptions& options, const EvalProgress& progress = {});

}  // namespace lp
