// Stage "uncertainty" of a geometric calibration: the chosen model's projection uncertainty
// (calib/projection_uncertainty.h: linear, mrcal-style, and jackknife) over the image, what
// each estimate predicts for the cross-validation next to the measured one, and every
// candidate's own linear uncertainty for the table.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include "calib/model_selection.h"
#include "calib/projection_uncertainty.h"

namespace lp {

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
  // The cross-validation of the chosen model repeated over cv_splits deterministic balanced
  // splits (odd/even and three pseudo-random ones with a fixed seed; halves refitted warm
  // from the full fit), RMS over the splits: one split is one noisy draw, this is what the
  // forecasts are checked against in docs/calibration.md.
  double cv_repeated_px = 0;
  int cv_splits = 0;
  // The estimate reported as "the" uncertainty: "jackknife" when it was computed (it
  // predicted the measured cross-validation on the real sets; the linear one is optimistic
  // there, see docs/calibration.md), else "linear".
  std::string headline;
  const UncertaintyGrid& headline_grid() const { return headline == "jackknife" ? jackknife : rotation_fitted; }
};

struct UncertaintyOptions {
  // Grid of nx x ny cells over the image that the chosen model's uncertainty is mapped on.
  int nx = 48, ny = 36;
  // Each candidate's linear sigma is a summary over about this many covered pixels.
  int candidate_samples = 400;
  // The repeated cross-validation when the selection ranked on one split: over this many.
  int repeated_splits = 4;
  // Its independent parts on every core (calib/parallel_jobs.h); the report is the same.
  bool parallel = true;
};

// The linearised covariance (projection_uncertainty.h) of `fit` on `views` (its poses
// aligned with them); its board warp is a parameter of the solve when
// problem.solve.board_warp (warp_covariance filled).
LinearCovariance fit_covariance(const CalibrationProblem& problem, const ModelFit& fit, const ViewSubset& views);

// `pick`: the chosen row of `table` (its fit: fits.full); `leave_one_out`: view_leverage's
// models (the jackknife needs at least 3). Sets every candidate's linear_sigma_px and
// linear_forecast_cv_px. Progress stage "uncertainty" (one step).
UncertaintyReport calibration_uncertainty(const CalibrationProblem& problem, CandidateFits& fits,
                                          std::vector<ModelCandidate>& table, size_t pick,
                                          const SelectionReport& selection,
                                          const std::vector<CameraModel>& leave_one_out,
                                          const UncertaintyOptions& options = {}, const StageProgress& progress = {});

}  // namespace lp
