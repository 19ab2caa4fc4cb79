// eval temporal: where each sampler breaks on dynamic scenes with ground truth (flicker,
// jitter, lag; CONVENTIONS.md "Temporal"), every method through the live frame pipeline
// on every scenario built on every base map.
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <string>
#include <vector>

#include "eval/harness.h"
#include "eval/synthetic_sequence.h"
#include "eval/temporal_accuracy.h"
#include "sampling/frame_pipeline.h"

namespace lp {

struct EvalTemporalOptions {
  // Base map files; "scene" renders the procedural scene (latlong 512x256).
  std::vector<std::string> maps;
  std::vector<Method> methods = all_methods();
  std::vector<Scenario> scenarios = all_scenarios();
  int frames = 48;                      // per scenario
  int count = 256;                      // lights per frame (positive; ignored with auto_count)
  // --n auto: each method keeps the fewest lights within auto_options' target and measure
  // (sampling/auto_count.h), capped by frame_budget_ms when positive (frame_budget.h);
  // the chart then adds the light count and the back end's time per frame.
  bool auto_count = false;
  AutoCountOptions auto_options;
  double frame_budget_ms = 0;
  double frame_rate_hz = 21;
  FilterMode filter = FilterMode::Auto; // the pipeline's FIR filtering
  // Created; receives temporal.csv and temporal.svg (power and error per frame).
  std::string output_dir;
};

struct TemporalRow {
  std::string map, scenario, method;
  TemporalReport report;
  double ms_per_frame = 0;  // the pipeline's time per frame
  int delay = 0;            // the pipeline's filter delay, frames
  double mean_lights = 0;   // lights per frame, averaged (varies with auto_count)
};

struct EvalTemporalReport {
  std::vector<TemporalRow> rows;  // map x scenario x method, in that order
  std::string csv_path, svg_path;
  // The table of every row and where the files went.
  std::string summary() const;
  // {"csv", "chart", "rows": [every row; lag_frames null when never reached or no step]}.
  nlohmann::json to_json() const;
};

// InputError for sequence options that make no sequence (synthetic_sequence.h validate)
// or a map that cannot be read. Progress: one step per frame.
EvalTemporalReport evaluate_temporal(const EvalTemporalOptions& options, const EvalProgress& progress = {});

}  // namespace lp
