// Geometric calibration (issue 6): lens model + intrinsics from chessboard corners.
//
// calibrate() composes the stages, each with its own header, options and report:
//   detect       board_detect.h (detect_boards: every image, in parallel)
//   seed         calibration_seed.h: OpenCV's closed-form calibrators
//   solve        calibration_solve.h: Ceres (Kannala-Brandt, Mei) and mrcal (the others)
//   outliers     outlier_rejection.h: MAD-scaled rounds with one reference model
//   select       model_selection.h: every candidate on the views and odd/even halves,
//                cross-validation repeated over balanced splits, the fewest parameters
//                within the measured noise of the best
//   diagnose     view_diagnostics.h: residuals, coverage, jackknife leverage of each view
//   uncertainty  calibration_uncertainty.h: the chosen model's projection uncertainty
// The same corners always give bit-identical intrinsics (every mrcal solve is seeded
// deterministically from an OpenCV solution). calibration_run.h runs it on image files and
// reports it as `lightprobe calib geometric` prints it.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "calib/board_detect.h"
#include "calib/board_warp_choice.h"
#include "calib/calibration_problem.h"
#include "calib/calibration_uncertainty.h"
#include "calib/camera_model.h"
#include "calib/model_selection.h"
#include "calib/mrcal_optimization_inputs.h"
#include "calib/outlier_rejection.h"
#include "calib/projection_difference.h"
#include "calib/projection_uncertainty.h"
#include "calib/view_diagnostics.h"

namespace lp {

// Every stage's options in one flat struct (the defaults are the stages' own; see their
// headers for what each trades off).
struct CalibrateOptions {
  // Empty: select among `candidates`. Otherwise one candidate name (see below): no selection.
  std::string model;
  // Candidate names (lens_model.h candidate_name): LENSMODEL_PINHOLE,
  // LENSMODEL_STEREOGRAPHIC, plumb_bob (OpenCV's 5-coefficient model, fitted as
  // LENSMODEL_OPENCV5), LENSMODEL_KANNALA_BRANDT, LENSMODEL_OPENCV8,
  // LENSMODEL_SPLINED_STEREOGRAPHIC, LENSMODEL_OMNIDIR_MEI (Mei's unified model, cv::omnidir:
  // catadioptric cameras). Empty = all of them (all_candidate_names()).
  std::vector<std::string> candidates;
  // SolveOptions (calibration_problem.h).
  bool use_mrcal = SolveOptions{}.use_mrcal;
  int spline_order = SolveOptions{}.spline_order, spline_nx = SolveOptions{}.spline_nx,
      spline_ny = SolveOptions{}.spline_ny;
  // Fit the board's flex (mrcal's calobject_warp) in every solve: SolveOptions::board_warp.
  // With board_warp_auto, only where it repays its two parameters: after the outlier stage
  // (run with the warp, so that a flex is not taken for outliers) the stage's reference model
  // is fitted with and without it over balanced splits (calib/board_warp_choice.h), and the
  // calibration goes on with the warp only when it wins; CalibrationResult::board_warp_choice.
  // Sets of fewer than BoardWarpChoiceOptions::min_views keep the warp untested. On by
  // default: over six pairs of halves of each shared set the chosen pairs agreed as well or
  // better than with the warp always fitted, on every set (stereo 0.346 -> 0.274 px), and
  // on the synthetic halves of 16 views (docs/calibration.md, "Kept where it repays its
  // parameters").
  bool board_warp = SolveOptions{}.board_warp;
  bool board_warp_auto = true;
  int board_warp_splits = BoardWarpChoiceOptions{}.splits;
  // Perspective candidates (and the outlier stage's perspective reference) are not fitted
  // where a wide-angle fit sees the corners beyond this many degrees off its axis
  // (kPerspectiveFieldLimitDeg, lens_model.h; CandidateOptions and OutlierOptions::
  // perspective_field_limit_deg). Infinity: always fitted.
  double perspective_field_limit_deg = kPerspectiveFieldLimitDeg;
  // SelectionOptions (model_selection.h): what "fits" means, for images up to
  // kPixelLimitsLongSidePx across; calibrate() scales both by pixel_limit_scale.
  double fit_max_rms_px = SelectionOptions{}.fit_max_rms_px;
  double fit_max_cross_validation_px = SelectionOptions{}.fit_max_cross_validation_px;
  // OutlierOptions (outlier_rejection.h): k, floor_px, rounds, reference_views,
  // max_view_outlier_fraction.
  double outlier_k = OutlierOptions{}.k;
  double outlier_floor_px = OutlierOptions{}.floor_px;
  int outlier_rounds = OutlierOptions{}.rounds;
  int reference_views = OutlierOptions{}.reference_views;
  double max_view_outlier_fraction = OutlierOptions{}.max_view_outlier_fraction;
  // SelectionOptions (model_selection.h): k, floor_px, cv_splits, screen_factor,
  // noise_from_splits.
  double selection_k = SelectionOptions{}.k;
  double selection_floor_px = SelectionOptions{}.floor_px;
  int cv_splits = SelectionOptions{}.cv_splits;
  double selection_screen_factor = SelectionOptions{}.screen_factor;
  bool selection_noise_from_splits = SelectionOptions{}.noise_from_splits;
  // SelectionOptions::rule, min_rule_splits, perspective_field_deg, outfit_factor: the simplest unless beaten beyond the splits'
  // noise (default), or the fewest parameters within the noise of the best.
  SelectionRule selection_rule = SelectionOptions{}.rule;
  int selection_min_rule_splits = SelectionOptions{}.min_rule_splits;
  double selection_perspective_field_deg = SelectionOptions{}.perspective_field_deg;
  double selection_outfit_factor = SelectionOptions{}.outfit_factor;
  int selection_small_set_views = SelectionOptions{}.small_set_views;  // and small_set_cv_splits
  int selection_small_set_cv_splits = SelectionOptions{}.small_set_cv_splits;
  bool selection_race_dear_candidates = SelectionOptions{}.race_dear_candidates;
  // Jackknife leverage of each view for the chosen model (one extra fit per view);
  // LeverageOptions (view_diagnostics.h).
  bool leverage = true;
  double leverage_flag_factor = LeverageOptions{}.flag_factor;
  double leverage_min_px = LeverageOptions{}.min_px;
  // CoverageOptions (view_diagnostics.h).
  int coverage_nx = CoverageOptions{}.nx, coverage_ny = CoverageOptions{}.ny;
  double edge_band = CoverageOptions{}.edge_band;
  int min_edge_observations = CoverageOptions{}.min_edge_observations;
  // Step (px) of the pixel grid that projection differences are evaluated on; 0 = auto.
  int diff_step_px = 0;
  // Projection uncertainty of the chosen model (calibration_uncertainty.h) on a grid of
  // uncertainty_nx x uncertainty_ny cells over the image; the jackknife part needs
  // `leverage` (its leave-one-out fits).
  bool uncertainty = true;
  int uncertainty_nx = UncertaintyOptions{}.nx, uncertainty_ny = UncertaintyOptions{}.ny;
  // Run the independent solves of a stage (candidates, halves, splits, leave-one-out refits)
  // on every core (calib/parallel_jobs.h); the result is the same either way.
  bool parallel = true;
  // Called as the solve goes, from the calling thread: the stage ("outlier rejection",
  // "candidates", "repeated splits", "noise jackknife", "leverage", "uncertainty", then
  // "done"), steps done and steps in that stage. Empty: nothing is reported.
  StageProgress progress;
};

// The board warp fitted with the chosen model (BoardWarp, board_detect.h: mrcal's
// calobject_warp, the peak deflection in mm of a parabola along each board axis).
struct BoardWarpReport {
  bool fitted = false;  // CalibrateOptions::board_warp, and the chosen fit's solver fitted it
  BoardWarp mm{};       // {x2, y2}
  // One standard deviation of each, from the solve's linearised covariance
  // (sigma^2 (J^T J)^-1 over intrinsics, poses and warp; calib/projection_uncertainty.h);
  // NaN with sd_error saying why (splined models: their regularisation is not modelled).
  std::array<double, 2> sd_mm{std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN()};
  std::string sd_error;
};

struct CalibrationResult {
  CameraModel model;  // rms_reprojection_px, cross_validation_px filled
  std::string selected;  // candidate name
  // No candidate fits (see CalibrateOptions::fit_max_rms_px): the model is the least bad
  // one and should not be trusted; the CLI warns.
  bool no_model_fits = false;
  std::vector<ModelCandidate> table;
  std::vector<double> view_rms_px;        // per view (0 for views without board)
  std::vector<CornerResidual> residuals;  // every detected corner of views with a board
  int coverage_nx = 0, coverage_ny = 0;
  std::vector<int> coverage;  // coverage_ny x coverage_nx row-major, inlier corners per cell
  std::vector<ViewReport> views;
  double cross_validation_px = 0;  // chosen model, odd/even split
  double cross_validation_repeated_px = std::numeric_limits<double>::quiet_NaN();  // chosen, over cv_splits
  // What ranked the candidates: "repeated" (RMS over cv_splits splits) or "odd/even" (cv_splits
  // = 1, or no candidate survived the screening with every split fitted).
  std::string selected_on;
  int cv_splits = 1;
  // The rule that picked ("incumbent" or "simplest within noise") and the candidate the
  // simplest-within-noise rule picks (the rule of before, for comparison).
  std::string selection_rule;
  std::string simplest_within_noise;
  double selection_field_deg = std::numeric_limits<double>::quiet_NaN();  // SelectionReport::field_deg
  bool selection_perspective_first = false;                                 // SelectionReport::perspective_first
  // Jackknife standard error of the best candidate's odd/even cross-validation: the
  // selection's noise (unless selection_noise_from_splits).
  double cv_noise_px = 0;
  // Standard error of the best candidate's K-split mean from the spread of its per-split
  // values (sample SD / sqrt(K)); NaN with fewer than 2 splits.
  double cv_split_noise_px = std::numeric_limits<double>::quiet_NaN();
  // The tolerance applied: cv <= cv_best + selection_k * selection_noise_px (+ floor).
  double selection_noise_px = 0, selection_k = 0;
  bool selection_noise_from_splits = false;
  double cross_validation_median_px = 0;
  double heldout_rms_px = 0;
  int corners_total = 0, corners_rejected = 0, outlier_rounds = 0;
  std::string outlier_reference;  // the model the outliers were flagged against (lens_type_name)
  // Inlier corners in the outer edge_band of each side: left, right, top, bottom.
  std::array<int, 4> edge_observations{};
  bool corners_poorly_covered = false;  // some side has < min_edge_observations
  UncertaintyReport uncertainty;        // empty unless options.uncertainty
  BoardWarpReport board_warp;
  // How board_warp_auto decided (decided false: not asked, or it could not compare; the
  // warp then stays as asked).
  BoardWarpChoice board_warp_choice;
  // The chosen model's solve (views, corners with inlier weights, board poses): what mrcal's
  // optimization_inputs state (calib/mrcal_optimization_inputs.h).
  SolveRecord solve;
  // When the chosen model is not one of mrcal's (Kannala-Brandt, Mei): the candidate that is,
  // solved on the same views, with the lowest held-out RMS (mean over the splits) among those
  // within CalibrateOptions::fit_max_rms_px (else the lowest RMS, fits_poorly). What a
  // .cameramodel output holds then, so that mrcal's tools have the calibration to work on;
  // median_from_chosen_px says how far it projects from the choice over the covered area
  // (rotation fitted out), same_ray_from_chosen_px the same for one ray in both frames: its
  // own solve may tilt the camera frame (1 degree on fisheye1: 5.6 px), and for a light probe
  // the frame is the light's direction. Empty when the choice is an mrcal model or no mrcal
  // candidate fitted.
  struct MrcalStandIn {
    std::string name;  // candidate name
    CameraModel model;
    SolveRecord solve;
    double rms_px = 0, heldout_rms_px = 0, median_from_chosen_px = 0, same_ray_from_chosen_px = 0;
    bool fits_poorly = false;
  };
  std::optional<MrcalStandIn> mrcal_stand_in;
};

// The pixel limits of a calibration (CalibrateOptions::fit_max_*, and the refusals of
// calibration_run.h) were set on images up to this long side. A corner's precision in
// pixels follows the optics' blur in pixels, which grows with the pixel count behind the
// same lens: fisheye1 enlarged 4x fits Kannala-Brandt at 1.50-1.75 px RMS (0.37 at its own
// 1032 px), over 1.5 px, and a 100-parameter spline on 6 views was chosen as the only model
// that "fitted".
constexpr double kPixelLimitsLongSidePx = 2048;
// max(1, long side / kPixelLimitsLongSidePx): the factor those limits are multiplied by.
double pixel_limit_scale(int width, int height);

// corners_per_view[i]: board.cols * board.rows pixel corners (row-major) or empty.
// Throws InputError (one line) on < 4 views with a board, a board with < 2 corners per
// side, a view with the wrong number of corners, corners outside width x height (images
// of another resolution), or an unknown model name.
CalibrationResult calibrate(const std::vector<std::vector<std::array<double, 2>>>& corners_per_view,
                            const BoardSpec& board, int width, int height, const CalibrateOptions& options = {});

}  // namespace lp

namespace lp {

// OpenCV run alone on the same corners, as a peer to compare with (docs/calibration.md):
// cv::fisheye::calibrate, cv::calibrateCamera (plumb_bob, rational) and
// cv::omnidir::calibrate, each as OpenCV returns it (no outlier rejection, no refinement),
// every corner of every view with a board. rms_px is recomputed over the views OpenCV
// posed (per corner, 2-D, as CalibrationResult's), cross-validation as calibrate's (odd /
// even views, projection difference over the covered area, rotation fitted out); seconds:
// the full-set solve.
struct PeerCalibration {
  std::string name;       // "cv::fisheye", "cv::calibrateCamera plumb_bob", ...
  std::string lensmodel;  // camera_model.h name
  bool ok = false;
  std::string error;
  double rms_px = 0, cross_validation_px = 0, seconds = 0;
  int views_posed = 0;
  CameraModel model;
};
// ONE solve of one candidate model (CalibrateOptions::candidates names) on every corner of
// every view with a board: no outlier rejection, no halves, no jackknifes. The unit that
// `eval calib` times against the OpenCV calibrator of the same model (cv::fisheye for
// Kannala-Brandt, cv::omnidir for Mei, calibrateCamera for plumb_bob / OpenCV8), on the
// same corners. rms_px as PeerCalibration's; seconds: wall time of the solve.
struct SingleSolve {
  bool ok = false;
  std::string error;
  CameraModel model;
  double rms_px = 0, seconds = 0;
};
SingleSolve solve_model_once(const std::vector<std::vector<std::array<double, 2>>>& corners_per_view,
                             const BoardSpec& board, int width, int height, const std::string& model,
                             const CalibrateOptions& options = {});

std::vector<PeerCalibration> calibrate_opencv_alone(const std::vector<std::vector<std::array<double, 2>>>& corners_per_view,
                                                    const BoardSpec& board, int width, int height, int diff_step_px = 0);

}  // namespace lp
