// eval estimators: MIS, BIS and SMC estimates of reflected radiance at shading points lit
// by live maps (Kronander et al. 2015, seed 002), against the exact pixel-sum reference:
// error (RMSE, variance across independent runs), frame-to-frame error (temporal noise)
// and time per estimate, per estimator x sample budget x glossiness, plus a sweep of the
// SMC parameters the paper calls sensitive.
//
// The harness writes estimators.csv, estimators_by_sequence.csv and estimators.svg (and,
// with the sweep, smc_sweep.csv and smc_sweep.svg) into options.output_dir. Errors are
// relative to each shading point's mean reference over the sequence, on luminance.
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "eval/synthetic_sequence.h"
#include "eval/harness.h"

namespace lp {

struct EvalEstimatorsOptions {
  // Base maps ("scene": the procedural scene), each run through every scenario, or
  // directories holding a recorded sequence (.exr/.hdr/.pfm, in name order).
  std::vector<std::string> inputs;
  // mis, bis, bis-mix, smc, smc-mix; -mix: BIS, and SMC's BIS initialisation, with half the
  // proposals from the map.
  std::vector<std::string> estimators{"mis", "bis", "bis-mix", "smc", "smc-mix"};
  std::vector<int> budgets{4, 16, 64, 256};  // samples with a visibility test per estimate
  std::vector<Scenario> scenarios{Scenario::MovingLight, Scenario::AbruptSwitch, Scenario::Flicker};  // on base maps
  int frames = 12;           // per scenario (a directory: its first `frames` maps); >= 2
  int repeats = 4;           // independent runs per estimate (the variance is across them); >= 2
  int width = 256, height = 128;  // every map is resampled to this latlong size (2H x H) first
  int bis_m = 8;             // BIS proposals per resampled sample (M = bis_m N)
  double ray_cost_us = 0;    // modelled cost of one visibility test, added to the measured time
  bool sweep = true;         // the SMC parameter sweep (budget 16, from smc-mix)
  uint64_t seed = 1;
  std::string output_dir;    // created if missing
};

// Errors of one configuration accumulated over shading points, frames and runs; each
// error is relative to its point's mean reference. NaN where nothing was accumulated.
struct EstimatorErrors {
  double sq = 0, sum = 0;  // squared and signed relative errors
  long n = 0;
  double var = 0;          // variance across runs, per point and frame
  long var_n = 0;
  double temporal = 0;     // |frame-to-frame change - the reference's change|
  long temporal_n = 0;
  double seconds = 0;      // thread CPU time of the estimates
  long estimates = 0;
  double rays = 0;         // visibility tests
  double ray_cost_s = 0;   // modelled seconds per visibility test
  void merge(const EstimatorErrors& o);
  double rmse() const { return n ? std::sqrt(sq / double(n)) : NAN; }
  double mean_error() const { return n ? sum / double(n) : NAN; }
  double variance() const { return var_n ? var / double(var_n) : NAN; }
  double temporal_noise() const { return temporal_n ? temporal / double(temporal_n) : NAN; }
  // Measured CPU time plus the modelled cost of the visibility tests.
  double us() const { return estimates ? 1e6 * (seconds + rays * ray_cost_s) / double(estimates) : NAN; }
  double rays_per_estimate() const { return estimates ? rays / double(estimates) : NAN; }
};

struct EstimatorsRow {
  std::string estimator;
  std::string variant;  // "" in the main comparison; the sweep's one change otherwise
  std::string group;    // the lobe ("all": every lobe) or, in by_sequence, the sequence
  int budget = 0;
  EstimatorErrors errors;
};

struct EvalEstimatorsReport {
  struct Sequence {
    std::string name;  // "scene/flicker", or a directory's name
    size_t frames = 0;
  };
  std::vector<Sequence> sequences;
  std::vector<std::string> estimators;     // as asked, in order
  std::vector<EstimatorsRow> rows;         // estimator x budget x (each lobe, then "all")
  std::vector<EstimatorsRow> sweep;        // the SMC sweep, same shape; empty without it
  std::vector<EstimatorsRow> by_sequence;  // every configuration x sequence, over all lobes
  int frames = 0;                          // per scenario, as asked
  size_t shading_points = 0;
  int repeats = 0;
  double ray_cost_us = 0;
  double reference_seconds = 0, seconds = 0;
  std::string csv_path, chart_path, sweep_csv_path;  // sweep_csv_path: "" without the sweep

  // The table `lightprobe eval estimators` prints.
  std::string summary() const;
  // The report `lightprobe eval estimators --json` emits.
  nlohmann::json to_json() const;
};

// Throws lp::InputError naming the option (by its command-line flag) it refuses.
void validate(const EvalEstimatorsOptions& options);
// Loads the inputs (InputError naming a missing, unreadable or black map), runs every
// configuration and writes the files. progress: one step per frame and configuration.
EvalEstimatorsReport evaluate_estimators(const EvalEstimatorsOptions& options, const EvalProgress& progress = {});

}  // namespace lp
