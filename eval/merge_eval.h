// eval merge: does weighting cameras by their distance to the point being lit (Nikodym,
// Havran, Bittner 2013, section 4; sampling/merge_cameras.h position_weights) bring the
// merged lights closer to what a camera at that point would see than equal weights do?
//
// Their Fig. 8/9 setup, on a synthetic room where the light really changes with position
// (estimate/walkthrough.h default_room: three lamps 2.5 m high and a window; the probes
// are rendered exactly, render_room_probe): four cameras at the corners of a square at
// eye height, the square's side 1 m as theirs; targets on a grid over the square (its
// centre, where every weighting is equal, included). At each target the truth is a camera
// placed there: its map is the reference of the CONVENTIONS.md yardstick (diffuse, glossy
// s = 10 and 100; no shadowed term), and the merged lights of the four cameras are scored
// against it, per method (pharr merges by index, q2tree merges trees) and weighting
// (equal; inverse distance to the power p). The target camera's own lights at the same n
// are the floor: the sampling error alone, no merge.
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <string>
#include <vector>

#include "core/vec3.h"
#include "eval/harness.h"
#include "sampling/sampler.h"

namespace lp {

struct EvalMergeOptions {
  // The square's centre (m, room frame): beside the 30000 cd/m2 lamp at (2, 2, 2.5), so
  // that its irradiance changes about two-fold across the square.
  Vec3 centre{2.0, 2.4, 1.6};
  double side = 1.0;          // m, as the paper's rig
  int grid = 5;               // targets per side of the square (>= 2; odd includes the centre)
  std::vector<double> powers = {1, 2};  // inverse-distance powers, beside equal weights
  std::vector<Method> methods = {Method::Pharr, Method::Q2Tree};
  int n = 64;                 // lights per camera and of the merge
  int map_width = 128;        // latlong maps width x width / 2
  int samples = 4;            // rays per pixel edge when rendering a probe
  std::string output_dir;     // created; receives merge.csv and merge.svg ("" writes nothing)
};

struct MergeEvalRow {
  std::string method, weighting;  // weighting: "equal", "1/d^2", ..., "target camera"
  Vec3 target;
  double distance_to_centre = 0;  // m
  double diffuse = 0, glossy10 = 0, glossy100 = 0;
};

// Means over the targets off the centre, per method and weighting.
struct MergeEvalSummary {
  std::string method, weighting;
  double diffuse = 0, glossy10 = 0, glossy100 = 0;
  double diffuse_at_centre = 0;
  int wins_over_equal = 0, targets = 0;  // off-centre targets where the diffuse error is below equal weights'
};

struct EvalMergeReport {
  std::vector<MergeEvalRow> rows;         // method x target x weighting
  std::vector<MergeEvalSummary> summary_rows;
  std::string csv_path, chart_path;
  std::string summary() const;   // the table of means and where the files went
  nlohmann::json to_json() const;
};

// InputError on a grid under 2, a side or n that is not positive, a negative power or no
// methods. Progress: one step per target.
EvalMergeReport evaluate_merge(const EvalMergeOptions& options, const EvalProgress& progress = {});

}  // namespace lp
