// The eval handlers, spread over the stage files until their harnesses move to eval/.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "cli/commands.h"

namespace lp::cli {

struct EvalEstimatorsArgs {
  std::vector<std::string> inputs;  // base maps ("scene": the procedural scene) or sequence directories
  // bis-mix / smc-mix: BIS, and SMC's BIS initialisation, with half the proposals from the map
  std::string estimators = "mis,bis,bis-mix,smc,smc-mix";
  std::string budgets = "4,16,64,256";  // samples with a visibility test per estimate
  std::string scenarios = "moving-light,abrupt-switch,flicker";  // applied to base maps
  int frames = 12;                  // per scenario (a directory: its first `frames` maps)
  int repeats = 4;                  // independent runs per estimate (variance across them)
  std::string size = "256x128";     // every map is resampled to this latlong size first
  int bis_m = 8;                    // BIS proposals per resampled sample (M = bis_m N)
  double ray_cost_us = 0;           // modelled cost of one visibility test, added to the measured time
  bool sweep = true;                // the SMC parameter sweep (budget 16)
  bool quick = false;               // demo: 4 frames, 2 repeats, budgets 4,16,64, no sweep
  uint64_t seed = 1;
  std::string output_dir;
};
int run_eval_estimators(const EvalEstimatorsArgs& args, const Output& out);

// eval calib: our calibration next to OpenCV run alone on the same detected corners
// (images given), and/or a sweep on synthetic corners (views x noise -> error vs truth).
struct EvalCalibArgs {
  std::vector<std::string> images;  // one camera's chessboard views; may be empty with --sweep
  std::string board = "9x6";
  double square_mm = 30;
  bool sweep = false;
  std::string output_dir;
};
int run_eval_calib(const EvalCalibArgs& args, const Output& out);

struct EvalMetadataArgs {
  std::string input_dir;            // from synth walkthrough
  std::string output_dir;
  std::string fractions = "0.1,0.25,0.5,0.75,1";
  double root_size = 0;             // 0: twice the room's larger side
  double min_size = 1;
};
int run_eval_metadata(const EvalMetadataArgs& args, const Output& out);

}  // namespace lp::cli
