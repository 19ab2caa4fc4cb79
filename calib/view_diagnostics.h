// After the model is chosen (model_selection.h): how it fits each view and corner, where the
// boards were (coverage), and how much each view moves the answer (jackknife leverage).
#pragma once

#include <array>
#include <string>
#include <vector>

#include "calib/calibration_problem.h"
#include "calib/lens_model.h"

namespace lp {

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

struct CoverageOptions {
  // Inlier corners are counted on a grid of nx x ny cells over the image.
  int nx = 16, ny = 12;
  // The edge bands are the outer edge_band of each side; fewer than min_edge_observations
  // inlier corners in one of them: the model is extrapolated there (a warning).
  double edge_band = 0.15;
  int min_edge_observations = 10;
};

struct ViewDiagnostics {
  std::vector<double> view_rms_px;        // per view as given (0 for views without board)
  std::vector<CornerResidual> residuals;  // every detected corner of views that can be posed
  int coverage_nx = 0, coverage_ny = 0;
  std::vector<int> coverage;              // coverage_ny x coverage_nx row-major, used inlier corners
  std::array<int, 4> edge_observations{}; // used inlier corners in the band: left, right, top, bottom
  bool corners_poorly_covered = false;    // some side has < min_edge_observations
  int corners_total = 0, corners_rejected = 0;
};

// Residuals of the chosen fit (`chosen`: poses of the used views in order); views left out
// are posed under its intrinsics (skipped when they cannot be). Fills rejected_corners, used
// and rms_px of view_reports (indexed by BoardView::index).
ViewDiagnostics diagnose_views(const CalibrationProblem& problem, const std::vector<BoardView>& views,
                               const std::vector<char>& view_used, const ModelFit& chosen,
                               std::vector<ViewReport>& view_reports, const CoverageOptions& options = {});

struct LeverageOptions {
  // Flagged when leverage > flag_factor * median and > min_px (a view that moves the model
  // by a few hundredths of a pixel is not worth a look, however it ranks).
  double flag_factor = 3.0;
  double min_px = 0.05;
  // The leave-one-out refits on every core (calib/parallel_jobs.h); the same numbers.
  bool parallel = true;
};

// Jackknife leverage of each used view for the chosen candidate `type`: the fit without it
// (warm from `chosen`), RMS projection change over `mask`. Fills leverage_px and influential
// of view_reports; returns the leave-one-out models (for the jackknife uncertainty).
// Progress stage "leverage".
std::vector<CameraModel> view_leverage(const CalibrationProblem& problem, const std::vector<BoardView>& views,
                                       const std::vector<char>& view_used, LensType type, const ModelFit& chosen,
                                       const std::vector<uint8_t>& mask, int step,
                                       std::vector<ViewReport>& view_reports, const LeverageOptions& options = {},
                                       const StageProgress& progress = {});

}  // namespace lp
