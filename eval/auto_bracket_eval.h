// eval auto-bracket: frames per HDR map against HDR error, for the auto-bracketing planner
// (hdr/auto_bracket.h) and fixed 3- and 5-exposure brackets, on synthetic sequences of
// known radiance whose range changes (issue 20 item 1):
//   lamp    a dim room (0.5 .. 2, 2 stops); a small lamp (1.4 % of the pixels) switches
//           from 0.8 to 2000 halfway (12 stops)
//   window  a window (4.7 % of the pixels) opens over the middle half of the sequence: its
//           radiance rises geometrically from 1 to 300 (9 stops)
//   cloud   a sky (2 .. 8) with a sun (0.16 % of the pixels) of 5e4 (14.6 stops); a cloud
//           (radiance 10) covers the sun in the middle third, letting 1e-3 of it through
// Every frame is photographed with hdr/synthetic_bracket.h (exposure scale 1: code = L t
// for the linear response; shot and read noise; 8 bits) at the bracket's times and merged
// through the true response (hdr/merge.h). The auto strategy plans each frame's bracket
// from the previous frame's fused map, as the live stream does (its first frame uses the
// fixed 3-bracket), so it lags a switch by one frame.
// Error: CONVENTIONS.md's HDR measure (hdr/hdr_accuracy.h: median and p95 |log10 Y error|
// after one global scale), and the error of the map's power (sum of Y, after the same
// scale), which a clipped light ruins while hiding from the p95 (it is a few pixels).
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <string>
#include <vector>

#include "eval/harness.h"
#include "hdr/auto_bracket.h"
#include "hdr/synthetic_bracket.h"

namespace lp {

struct EvalAutoBracketOptions {
  std::vector<std::string> scenarios{"lamp", "window", "cloud"};
  int frames = 24;              // per scenario
  int width = 128, height = 64;  // radiance images
  ResponseCurve response = ResponseCurve::Linear;
  int bit_depth = 8;
  // Fixed brackets, 3 stops apart around 1/8 s (the room's median reads code 0.125).
  std::vector<double> fixed3{1 / 64., 1 / 8., 1.};
  std::vector<double> fixed5{1 / 4096., 1 / 512., 1 / 64., 1 / 8., 1.};
  ExposureLimits limits;        // the camera: 1e-5 .. 1 s, at most 7 exposures
  AutoBracketOptions planner;
  uint64_t seed = 1;
  std::string output_dir;       // created; receives auto_bracket.csv (one row per frame and strategy)
};

// One strategy on one scenario, over its frames.
struct AutoBracketRow {
  std::string scenario, strategy;  // strategy: auto, fixed3, fixed5
  double frames_per_map = 0;       // mean bracket size
  double median_log10 = 0;         // mean over frames of the frame's median |log10 error|
  double p95_log10 = 0;            // mean over frames of the frame's p95
  double worst_p95_log10 = 0;      // the worst frame's p95
  double power_error = 0;          // mean over frames of |power - true power| / true power
  double worst_power_error = 0;
  int replans = 0;                 // auto: plan changes after the first plan
  struct Frame {
    size_t exposures = 0;
    double median_log10 = 0, p95_log10 = 0, power_error = 0;
  };
  std::vector<Frame> frames;       // each frame's, in order
};

struct EvalAutoBracketReport {
  std::vector<AutoBracketRow> rows;  // scenario x strategy (auto, fixed3, fixed5)
  std::string csv_path;
  std::string summary() const;
  nlohmann::json to_json() const;    // {"csv", "rows": [...]}
  const AutoBracketRow& row(const std::string& scenario, const std::string& strategy) const;
};

// The radiance of a scenario's frame (InputError for an unknown scenario).
RgbImage auto_bracket_scene(const std::string& scenario, int frame, int frames, int width, int height);

// InputError on an unknown scenario or bad options. Progress: one step per scenario.
EvalAutoBracketReport evaluate_auto_bracket(const EvalAutoBracketOptions& options, const EvalProgress& progress = {});

}  // namespace lp
