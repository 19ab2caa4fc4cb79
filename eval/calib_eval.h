// eval calib: our geometric calibration next to OpenCV's calibrators run alone on the
// same detected corners (images given), and/or a sweep over views and corner noise on
// synthetic corners of a known 190 deg Kannala-Brandt camera (error against the truth).
//
// The harness writes calib_compare.csv and calib_speed.csv (images), calib_sweep.csv and
// calib_sweep.svg (sweep) into options.output_dir.
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "calib/board_detect.h"
#include "calib/geometric.h"
#include "eval/harness.h"

namespace lp {

struct EvalCalibOptions {
  std::vector<std::string> images;  // one camera's chessboard views; may be empty with sweep
  BoardSpec board;                  // the images' board (the sweep uses its own 10x7, 40 mm)
  bool sweep = false;               // views 4..20, noise 0.05..0.5 px on synthetic corners
  std::string output_dir;           // created if missing
};

// Our calibration and OpenCV's alone, on the corners detected in the images.
struct CalibComparison {
  int views = 0;                    // images with the board found
  CalibrationResult ours;           // the whole selection, every candidate
  double ours_seconds = 0;
  std::vector<PeerCalibration> peers;  // calibrate_opencv_alone, in its order
  // Speed, model for model: ONE solve of ours against the OpenCV calibrator of the same
  // model alone on the same corners, each the fastest of `speed_repeats` interleaved runs,
  // and the whole `--model NAME` calibration for scale. NaN where a solver failed.
  struct Speed {
    std::string model, peer;
    double ours_rms_px, peer_rms_px, ours_one_solve_seconds, peer_seconds, ratio, model_command_seconds;
  };
  std::vector<Speed> speed;
  int speed_repeats = 3;
};

// One sweep configuration: RMS projection difference to the true model (rotation fitted
// out) over the pixels within the corners' field, over three noise draws; NaN where a
// solver never succeeded. Seconds: mean over the successful draws.
struct CalibSweepRow {
  int views = 0;
  double noise_px = 0, max_corner_deg = 88;
  double ours_px = 0, ours_kb_px = 0, cv_fisheye_px = 0, cv_rational_px = 0;
  double ours_seconds = 0, ours_kb_seconds = 0, cv_fisheye_seconds = 0;
  double ours_kb_one_solve_seconds = 0;  // one solve (solve_model_once), against cv_fisheye_seconds
};

struct EvalCalibReport {
  std::string output_dir;
  std::optional<CalibComparison> comparison;  // with images
  std::vector<CalibSweepRow> sweep;           // with sweep

  // The tables `lightprobe eval calib` prints.
  std::string summary() const;
  // The report `lightprobe eval calib --json` emits.
  nlohmann::json to_json() const;
};

// Throws lp::InputError naming the option (by its command-line flag) it refuses.
void validate(const EvalCalibOptions& options);
// Detects the boards (InputError when fewer than 4 views have one), calibrates, compares,
// sweeps and writes the files. progress: one step per image, then per sweep draw.
EvalCalibReport evaluate_calib(const EvalCalibOptions& options, const EvalProgress& progress = {});

}  // namespace lp
