// A geometric calibration from image files to camera files, and its report: what
// `lightprobe calib geometric` runs (the CLI parses, calls these, prints summary() or
// to_json()).
//
// calibrate_images: detect the board in every image (board_detect.h detect_boards), calibrate
// (geometric.h), and on request leave out the most influential views and solve again.
// write_calibration_files: .cameramodel where mrcal has the model (with mrcal's
// optimization_inputs, so that mrcal's uncertainty and residual tools run on it), OpenCV YAML
// wherever OpenCV has it (CONVENTIONS.md "Camera models"), and the pictures
// (calibration_report.h).
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "calib/board_detect.h"
#include "calib/geometric.h"

namespace lp {

struct GeometricCalibrationOptions {
  DetectOptions detect;
  CalibrateOptions calibrate;
  // Influential views (a few close-ups can move the whole answer): up to this many of those
  // flagged (CalibrateOptions::leverage), highest leverage first, are left out and everything
  // is solved again; both answers are reported. Never below 5 used views (the 4 a
  // calibration needs, plus one so each half keeps two). 0: report them only.
  int drop_influential = 0;
};

struct DroppedView {
  size_t view = 0;          // image index
  double leverage_px = 0;   // its leverage in the first solve
};

struct GeometricCalibration {
  BoardSpec board;
  BoardDetections detections;
  // The corners the final solve used (dropped views emptied) and its result.
  std::vector<std::vector<std::array<double, 2>>> corners;
  CalibrationResult result;
  double solve_seconds = 0;  // every solve, the re-solve without dropped views included
  int drop_influential = 0;  // as requested
  std::vector<DroppedView> dropped;
  // The first solve's answer when views were dropped.
  struct Answer {
    std::string selected;
    double rms_px = 0, cross_validation_px = 0, heldout_rms_px = 0;
  };
  std::optional<Answer> before_dropping;
  // Set by write_calibration_files.
  std::vector<std::string> written;  // camera files, in the order written
  std::vector<std::string> notes;    // a format that was skipped, and why (one line each)
  bool optimization_inputs = false;  // the .cameramodel carries mrcal's (mrcal_optimization_inputs.h)
  std::string picture_stem;          // <stem>_residuals.png, <stem>_coverage.png
  bool uncertainty_picture = false;  // <stem>_uncertainty.png (when there is an uncertainty)

  // The report as text, lines ending in '\n': the notes, detection and solve times, the
  // candidate table, the selection, dropped and influential views, warnings, the projection
  // uncertainty, the cross-validation and the files written.
  std::string summary() const;
  // The same as one JSON object (numbers a script reads; NaN and inf as null).
  std::string to_json() const;
};

// InputError (one line, naming the file) when `output` is not .cameramodel / .yaml / .yml or
// its directory does not exist, or ("--model: ...") when `model` is neither empty nor a
// candidate name: checked before minutes of work.
void check_calibration_output(const std::string& output, const std::string& model = "");

// The calibration of detected boards (options.detect unused). InputError when fewer than 4
// images show the board or the calibration refuses the corners. Progress of the solve:
// options.calibrate.progress.
GeometricCalibration calibrate_detections(BoardDetections detections, const BoardSpec& board,
                                          const GeometricCalibrationOptions& options = {});
// detect_boards, then calibrate_detections (InputError also when an image cannot be read or
// the images differ in size). on_image_detected: as detect_boards' on_image.
GeometricCalibration calibrate_images(const std::vector<std::string>& images, const BoardSpec& board,
                                      const GeometricCalibrationOptions& options = {},
                                      const std::function<void()>& on_image_detected = {});

// Writes the camera files for `output` (.cameramodel: it and the .yaml beside it; .yaml:
// only it) and the pictures into report_dir (empty: output's directory), each atomically;
// records them in `run`. InputError when the model fits no format the output asks for.
void write_calibration_files(GeometricCalibration& run, const std::string& output, const std::string& report_dir = "");

}  // namespace lp
