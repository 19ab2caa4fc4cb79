// eval unwrap: unwrapping error and probe-centre error on synthetic probes rendered from
// known maps (CONVENTIONS.md "Unwrapping"): a mirror ball (orthographic and at 10 radii,
// clean and with 2 % noise) found by detection, and a 190-degree equidistant fisheye,
// each unwrapped to latlong 256x128 and compared with the map resampled to that size.
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <string>
#include <vector>

#include "eval/harness.h"
#include "probe/unwrap_accuracy.h"

namespace lp {

struct EvalUnwrapOptions {
  // Latlong map files; "scene" renders the procedural scene (latlong 1024x512).
  std::vector<std::string> maps;
  // Created; receives unwrap.csv.
  std::string output_dir;
};

struct UnwrapRow {
  std::string map, probe;
  UnwrapError error;
  double centre_error_px = 0, radius_error_px = 0;  // detected against true ball / image circle
  double ms = 0;                                      // detection and unwrapping
};

struct EvalUnwrapReport {
  std::vector<UnwrapRow> rows;  // map x probe (five per map), in that order
  std::string csv_path;
  // The table of every row and where the file went.
  std::string summary() const;
  // {"csv", "rows": [every row]}.
  nlohmann::json to_json() const;
};

// InputError when a map cannot be read. Progress: one step per map.
EvalUnwrapReport evaluate_unwrap(const EvalUnwrapOptions& options, const EvalProgress& progress = {});

}  // namespace lp
