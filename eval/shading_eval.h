// eval shading: what angular-region culling, glossy two-strata sets and clustering
// (Havran et al. 2005, section 4) buy in shading speed and cost in accuracy, per map and
// light count.
//
// Timing: one thread's CPU time, the same compiled loops for every variant
// (render/reference_shader.h), random normals and reflected view directions from a fixed
// seed, the best of five interleaved runs; table building is timed separately. Errors:
// CONVENTIONS.md diffuse and glossy measures against the map's own integral (no shadowed
// measure: the shader has no occluders).
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <string>
#include <vector>

#include "eval/harness.h"
#include "render/reference_shader.h"
#include "sampling/sampler.h"

namespace lp {

struct EvalShadingOptions {
  // Map files; "scene" renders the procedural scene (latlong 1024x512).
  std::vector<std::string> maps;
  // Light counts |H| (positive); L holds low_per_high times as many.
  std::vector<int> counts = {64, 256, 1024, 4096};
  // The tables: regions, LUT, glossy sets, clustering, region copies.
  ShadingOptions shading;
  // A progressive sampler for the lights (pharr or hemigon): H is a prefix of L.
  Method method = Method::Pharr;
  // Shading points per timing run; 0: ~8M light evaluations (4M / n, 256 .. 32768).
  int points = 0;
  // Shade points in the order of their normal's region (as neighbouring pixels of a
  // smooth surface come) instead of at random: cache effects, not errors, change.
  bool coherent = false;
  // Created; receives shading.csv and shading.svg.
  std::string output_dir;
};

struct ShadingRow {
  std::string map, variant;  // map label ("median" for the medians over maps)
  int n = 0;
  int lights = 0;          // lights the variant holds (c: |H| + |L|)
  double visits = 0;       // mean lights visited per point (diffuse + glossy loops)
  double ns = 0;           // ns per shaded point
  double speedup = 0;      // all-lights time / this time
  double visit_ratio = 0;  // all-lights visits / these visits: the speed-up if time were visits
  double build_ms = 0;     // table build time this variant needs beyond the light list
  double diffuse = 0, glossy10 = 0, glossy100 = 0;
};

struct EvalShadingReport {
  // The angular regions, built once and shared by every map and count.
  int regions = 0, cone_regions = 0, lut_face_size = 0;
  double region_max_radius_deg = 0, cone_max_radius_deg = 0, regions_build_ms = 0;
  std::vector<ShadingRow> rows;     // map x count x variant, in that order
  std::vector<ShadingRow> medians;  // variant x count: medians over the maps
  size_t maps = 0;
  std::string csv_path, svg_path;
  // The regions line, the table of medians and where the files went.
  std::string summary() const;
  // {"csv", "chart", the regions' numbers, "summary": medians, "points": every row}.
  nlohmann::json to_json() const;
};

// InputError naming the map when a map cannot be read or sampled, or on bad table
// options or counts. Progress: one step per map and count.
EvalShadingReport evaluate_shading(const EvalShadingOptions& options, const EvalProgress& progress = {});

}  // namespace lp
