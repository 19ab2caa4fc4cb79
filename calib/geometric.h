// Geometric calibration (issue 6): lens model + intrinsics from chessboard corners.
//
// Candidate models are fitted with OpenCV (cv::fisheye for Kannala-Brandt and cv::omnidir
// for Mei's unified model, each refined by a joint Ceres solve; calibrateCamera for
// pinhole / plumb_bob / rational) and with mrcal (stereographic, OpenCV8 polish,
// splined stereographic), every mrcal solve seeded deterministically from an OpenCV
// solution, so the same corners always give bit-identical intrinsics.
//
// Accuracy is reported as cross-validation: the views are split into odd/even halves,
// each half calibrated alone, and the two models compared over the area the boards
// covered (unproject with A, best rotation between the two camera frames, project with
// B): the pixel disagreement is what a user can expect from recalibrating (mrcal's
// "projection difference"). The model chosen is the one with the fewest parameters whose
// cross-validation, repeated over cv_splits balanced splits (RMS over the splits), is within
// the noise of the best candidate's: it exceeds the best's by at most selection_k times the
// jackknife standard error of the best's odd/even cross-validation (each view left out of
// its half in turn, that half refitted, the comparison repeated).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "calib/board_detect.h"
#include "calib/camera_model.h"
#include "calib/projection_uncertainty.h"

namespace lp {

struct CalibrateOptions {
  // Empty: select among `candidates`. Otherwise one candidate name (see below): no selection.
  std::string model;
  // Candidate names: "LENSMODEL_PINHOLE", "LENSMODEL_STEREOGRAPHIC", "plumb_bob" (OpenCV's
  // 5-coefficient model, stored as LENSMODEL_OPENCV8 with k4..k6 = 0),
  // "LENSMODEL_KANNALA_BRANDT", "LENSMODEL_OPENCV8", "LENSMODEL_SPLINED_STEREOGRAPHIC",
  // "LENSMODEL_OMNIDIR_MEI" (Mei's unified model, cv::omnidir: catadioptric cameras).
  // Empty = all of them.
  std::vector<std::string> candidates;
  bool use_mrcal = true;  // false: OpenCV paths only (stereographic/splined unavailable)
  // Splined model: cubic, Nx x Ny control points, fov from the seed.
  int spline_order = 3, spline_nx = 8, spline_ny = 6;
  // A candidate "fits" when its reprojection RMS is at most fit_max_rms_px and its
  // cross-validation at most fit_max_cross_validation_px; CalibrationResult::no_model_fits
  // when none does. Chessboard corners are good to a few tenths of a pixel, so a model
  // that misses them by 1.5 px RMS (or whose two halves disagree by 5 px) is the wrong
  // lens model, not a noisy calibration.
  double fit_max_rms_px = 1.5;
  double fit_max_cross_validation_px = 5.0;
  // Outlier rejection: drop corners with |residual| > k * sigma (sigma = 1.4826 * MAD of
  // the residual components), never below `outlier_floor_px`; at most `outlier_rounds`.
  double outlier_k = 4.0;
  double outlier_floor_px = 0.25;
  int outlier_rounds = 5;
  // The outlier reference (the best-fitting of Kannala-Brandt, Mei and the rational model)
  // is chosen on at most this many views, evenly spaced, when there are more: on 63 views
  // fitting all three cost ~20 s, and the choice only needs to tell the lens family apart.
  int reference_views = 16;
  // A view loses its board when more than this fraction of its corners are outliers.
  double max_view_outlier_fraction = 0.5;
  // Model selection: the candidate with the fewest parameters among those with
  // cv - cv_best <= selection_k * noise + selection_floor_px, where noise is the jackknife
  // standard error of the best (lowest) cross-validation (CalibrationResult::cv_noise_px;
  // one warm refit of a half per view). k = 2: a model whose cross-validation differs from
  // the best's by less than two standard errors of such a measurement cannot be told apart
  // from it by these views. (The standard error of the paired difference was tried first:
  // a wrong model's cross-validation jumps so much when a view is left out that its own
  // spread made a 1.5 px pinhole "within noise" of a 0.1 px rational fit.) The floor only
  // matters for noise-free corners. Candidates with cross-validation above
  // fit_max_cross_validation_px never qualify, nor those whose held-out RMS (one half's model
  // on the other half's corners) exceeds the best's by more than selection_k / sqrt(residual
  // components) (relative): it is the precise statistic, and with few views the
  // cross-validation's spread is too wide to reject a stereographic model 1.3 px off on a
  // 190 deg lens (0.31 px for the best). (The full fit's RMS was used before: it falls with
  // every parameter, so a 100-parameter spline as the best disqualified every other model.)
  double selection_k = 2.0;
  double selection_floor_px = 0.005;
  // The cross-validation that ranks the candidates: repeated over cv_splits balanced splits
  // of the views (odd/even, then cv_splits - 1 pseudo-random ones from a fixed seed, none
  // repeated; each half refitted warm from the candidate's full fit), RMS over the splits.
  // One split is one noisy draw (its value for one setup scattered 0.18-0.77 px over four
  // noise draws); the mean of 4 was predicted within 0.69-1.35x by the jackknife on seven
  // real sets (docs/calibration.md). 4: the repeated value the forecasts were checked
  // against, at 3 extra splits' cost. 1 = the odd/even split alone (the rule before). Each extra split
  // costs two warm refits per candidate that is not screened out: failed, odd/even
  // cross-validation above fit_max_cross_validation_px, or above selection_screen_factor x
  // the best odd/even one (a single split scatters by ~2x, so 10x is hopeless, not noise).
  int cv_splits = 4;
  double selection_screen_factor = 10.0;
  // The tolerance's noise: false (default) = the jackknife standard error of the best
  // candidate's odd/even cross-validation (cv_noise_px), a conservative bound for the
  // K-split mean; true = the spread of the best's K per-split values / sqrt(K)
  // (cv_split_noise_px). See docs/calibration.md for the measurement that chose.
  bool selection_noise_from_splits = false;
  // Jackknife leverage of each view for the chosen model (one extra fit per view).
  bool leverage = true;
  // Flagged when leverage > factor * median and > leverage_min_px (a view that moves the
  // model by a few hundredths of a pixel is not worth a look, however it ranks).
  double leverage_flag_factor = 3.0;
  double leverage_min_px = 0.05;
  // Coverage grid (cells) and the edge-band warning.
  int coverage_nx = 16, coverage_ny = 12;
  double edge_band = 0.15;
  int min_edge_observations = 10;
  // Step (px) of the pixel grid that projection differences are evaluated on; 0 = auto.
  int diff_step_px = 0;
  // Projection uncertainty of the chosen model (calib/projection_uncertainty.h) on a grid
  // of uncertainty_nx x uncertainty_ny cells over the image; the jackknife part needs
  // `leverage` (its leave-one-out fits).
  bool uncertainty = true;
  int uncertainty_nx = 48, uncertainty_ny = 36;
  // Called as the solve goes, from the calling thread: the stage ("outlier rejection",
  // "candidates", "repeated splits", "noise jackknife", "leverage", "uncertainty"), steps
  // done and steps in that stage. Empty: nothing is reported.
  std::function<void(const std::string& stage, int done, int total)> progress;
};

// The chosen model's projection uncertainty (rays at infinity) and what each estimate
// predicts for the cross-validation, next to the measured one.
struct UncertaintyReport {
  bool linear_ok = false;
  std::string linear_error;        // why the linear estimate is missing (e.g. splined model)
  double sigma_px = 0;             // residual sigma per component used by the linear estimate
  UncertaintyGrid mean_frames;     // linear, mrcal's mean-frames (mean-pcam) method
  UncertaintyGrid rotation_fitted; // linear, camera rotation fitted out as cross-validation does
  UncertaintyGrid jackknife;       // empirical, leave-one-view-out spread (empty without leverage)
  // Predicted RMS odd/even difference over the covered area (the measured cross-validation's
  // pixels): linear from each half's own covariance (rotation fitted out), jackknife as
  // 2 x the full model's spread (two independent halves of half the views each).
  double predicted_cv_linear_px = 0;
  double predicted_cv_jackknife_px = 0;
  // The cross-validation of the chosen model repeated over cv_splits deterministic half
  // balanced splits (odd/even and three pseudo-random ones with a fixed seed; halves
  // refitted warm from the full fit), RMS over the splits: one split is one noisy draw, this is what the forecasts are
  // checked against in docs/calibration.md.
  double cv_repeated_px = 0;
  int cv_splits = 0;
  // The estimate reported as "the" uncertainty: "jackknife" when it was computed (it
  // predicted the measured cross-validation on the real sets; the linear one is optimistic
  // there, see docs/calibration.md), else "linear".
  std::string headline;
  const UncertaintyGrid& headline_grid() const { return headline == "jackknife" ? jackknife : rotation_fitted; }
};

struct ModelCandidate {
  std::string name;       // candidate name as in CalibrateOptions::candidates
  std::string lensmodel;  // camera_model.h name of the fitted model
  int params = 0;         // free intrinsics
  bool ok = false;
  std::string error;      // why the fit failed (when !ok)
  double rms_px = 0;                 // reprojection RMS (per corner, 2-D) of the full fit
  // One half's intrinsics on the other half's corners (poses re-solved with intrinsics
  // fixed: PnP on the unprojected rays, then pixel refinement), both ways; inf when some
  // view cannot be posed under the model (e.g. a pinhole model and rays near 90 deg).
  double heldout_rms_px = 0;
  double cross_validation_px = 0;    // RMS odd-vs-even projection difference, covered area
  double cross_validation_median_px = 0;
  // The cross-validation of each balanced split (CalibrateOptions::cv_splits; the first is
  // the odd/even one above) and their RMS, which ranks the candidates. Empty / NaN when the
  // candidate was screened out (see CalibrateOptions::selection_screen_factor) or
  // cv_splits = 1; inf when a half of some split could not be fitted.
  std::vector<double> cross_validation_splits_px;
  double cross_validation_repeated_px = std::numeric_limits<double>::quiet_NaN();
  bool within_noise = false;  // cv and held-out RMS within the noise of the best's (see options)
  // mrcal-style linearised projection uncertainty of this candidate's full fit (a ray at
  // infinity, rotation fitted out): the RMS 2-D sigma over the area the boards covered, and
  // the cross-validation it forecasts (2x that). NaN when not computed (options.uncertainty
  // off, splined models, singular normal equations). Reported beside the cross-validation;
  // it does not take part in the pick (it is 1.4-3.3x optimistic on real corners).
  double linear_sigma_px = std::numeric_limits<double>::quiet_NaN();
  double linear_forecast_cv_px = std::numeric_limits<double>::quiet_NaN();
  CameraModel model;
};

struct CornerResidual {
  int view = 0, corner = 0;  // view index as given, corner index (row-major)
  double dx = 0, dy = 0;     // observed - projected, px (final model)
  bool outlier = false;
};

struct ViewReport {
  bool has_board = false;
  bool used = false;
  std::string why;           // "" when used; else "no board", "too many outliers (..)", ...
  int corners = 0;           // detected
  int rejected_corners = 0;  // outliers
  double rms_px = 0;         // residual RMS of its inlier corners (final model)
  double leverage_px = 0;    // RMS projection change when left out (jackknife)
  bool influential = false;  // leverage > leverage_flag_factor * median (and > leverage_min_px)
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
  // Inlier corners in the outer edge_band of each side: left, right, top, bottom.
  std::array<int, 4> edge_observations{};
  bool corners_poorly_covered = false;  // some side has < min_edge_observations
  UncertaintyReport uncertainty;        // empty unless options.uncertainty
};

// corners_per_view[i]: board.cols * board.rows pixel corners (row-major) or empty.
// Throws InputError (one line) on < 4 views with a board, a board with < 2 corners per
// side, a view with the wrong number of corners, corners outside width x height (images
// of another resolution), or an unknown model name.
CalibrationResult calibrate(const std::vector<std::vector<std::array<double, 2>>>& corners_per_view,
                            const BoardSpec& board, int width, int height, const CalibrateOptions& options = {});

// The balanced splits the selection's repeated cross-validation uses, of `views` used views
// (in their order) into two halves: side 0/1 per view, odd/even first, then pseudo-random
// ones from a fixed seed, none equal to an earlier one or its complement; at most `splits`.
std::vector<std::vector<int>> balanced_view_splits(int views, int splits);

// Projection difference between two models (same image size): pixels on a grid of
// `step_px` where mask (width*height, row-major, nonzero = use; empty = whole image) is
// set and both models have a ray: unproject with a, rotate by the best-fitting rotation
// between the camera frames (or identity when !fit_rotation), project with b.
struct ProjectionDiff {
  double rms_px = 0, median_px = 0, max_px = 0;
  int samples = 0;
};
ProjectionDiff projection_difference(const CameraModel& a, const CameraModel& b, const std::vector<uint8_t>& mask,
                                     int step_px, bool fit_rotation = true);

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
