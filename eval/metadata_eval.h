// eval metadata: the diffuse error of lighting without a probe (the camera-metadata
// quadtree of estimate/, seed 003) at the query points of a `synth walkthrough`, next to
// real probes at the same points sampled by the existing samplers, the best any six
// sector lights can do, and the same head motion standing at each point. The model is
// built from a growing part of the walk (options.fractions), in four lookup variants.
//
// The harness writes metadata.csv and metadata.svg into options.output_dir.
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include "eval/harness.h"

namespace lp {

struct EvalMetadataOptions {
  std::string input_dir;   // from synth walkthrough: truth.json, track.jsonl, the probes
  std::string output_dir;  // created if missing
  std::vector<double> fractions{0.1, 0.25, 0.5, 0.75, 1};  // parts of the path to build the model from, each in (0, 1]
  double root_size = 0;    // root cell side, m; 0: twice the room's larger side
  double min_size = 1;     // smallest cell side, m
};

struct MetadataRow {
  std::string method;         // "probe pharr 6", "best six sectors", "metadata, root only", ...
  double fraction = 1;        // of the path used (1 for probes)
  size_t frames = 0;          // track frames the model was built from (0 for probes)
  double mean_error = 0, max_error = 0;  // diffuse rel. RMS error over the query points
  double mean_distance = 0;   // m, query point to the nearest visited position
  double seconds_per_query = 0;
  double cct_error = NAN;     // K, mean over sectors and query points (metadata rows)
};

struct EvalMetadataReport {
  std::vector<MetadataRow> rows;  // probes, best six sectors, standing (if recorded), then variants x fractions
  size_t queries = 0, frames = 0;  // query points; frames of the walk's track
  std::string csv_path, chart_path;

  // The table `lightprobe eval metadata` prints.
  std::string summary() const;
  // The report `lightprobe eval metadata --json` emits.
  nlohmann::json to_json() const;
};

// Throws lp::InputError naming the option (by its command-line flag) it refuses.
void validate(const EvalMetadataOptions& options);
// Reads the walkthrough (InputError naming a missing or malformed file), evaluates and
// writes the files. progress: one step per fraction of the walk.
EvalMetadataReport evaluate_metadata(const EvalMetadataOptions& options, const EvalProgress& progress = {});

}  // namespace lp
