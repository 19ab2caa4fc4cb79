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
  // The shadowed error; its reference is the slow part of a run.
  bool shadowed = true;
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
  size_t maps = 0;
  std::string csv_path, svg_path;
  // The table of medians and where the files went.
  std::string summary() const;
  // {"csv", "chart", "points": [every point]}.
  nlohmann::json to_json() const;
};

// InputError naming the map when a map cannot be read or sampled.
EvalSamplingReport evaluate_sampling(const EvalSamplingOptions& options, const EvalProgress& progress = {});

}  // namespace lp
