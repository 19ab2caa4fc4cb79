// eval hdr: error and time of HDR fusion (ours with the true, Debevec and Robertson
// responses; OpenCV's Debevec and Robertson) on synthetic brackets made from known
// radiance (CONVENTIONS.md "HDR": median and 95th-percentile |log10 L - log10 L_true|
// after one global scale). Times are the best of three runs; the floor is one pass over
// the bracket's pixels (the best of five), a merge's cost in units of memory traffic.
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <string>
#include <vector>

#include "eval/harness.h"
#include "hdr/hdr_accuracy.h"
#include "hdr/synthetic_bracket.h"

namespace lp {

struct EvalHdrOptions {
  // Radiance maps or images; "scene" renders the procedural scene (latlong 512x256).
  std::vector<std::string> maps;
  // The camera response of the synthetic brackets (3 exposures, 3 stops apart): linear,
  // gamma or scurve.
  ResponseCurve response = ResponseCurve::Gamma22;
  // Created; receives hdr.csv and hdr.svg.
  std::string output_dir;
};

struct HdrRow {
  std::string map, method;
  HdrError error;  // NaN medians and every pixel invalid when nothing usable came out
  double recover_ms = 0, merge_ms = 0, floor_ms = 0;
};

struct EvalHdrReport {
  std::vector<HdrRow> rows;  // map x method (six per map), in that order
  std::string csv_path, svg_path;
  // The table of every row and where the files went.
  std::string summary() const;
  // {"csv", "chart", "rows": [every row]}.
  nlohmann::json to_json() const;
};

// InputError when a map cannot be read or bracketed. Progress: one step per map.
EvalHdrReport evaluate_hdr(const EvalHdrOptions& options, const EvalProgress& progress = {});

}  // namespace lp
