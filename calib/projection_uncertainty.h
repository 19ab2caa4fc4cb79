// How well a calibration pins down the projection of a direction, across the image.
//
// Two estimates, both of the standard deviation (px) of the projection of a fixed ray at
// infinity (a light probe's directions are at infinity):
//  - linearised (mrcal's method): the observation noise sigma (from the residuals of the
//    final solve) propagated through the solve, Cov(params) = sigma^2 (J^T J)^-1 over the
//    intrinsics and every board pose, to the pixel of a fixed ray. The camera frame is
//    pinned down in one of two ways: "mean frames" (mrcal's mean-pcam: the ray is carried
//    into every board's frame and back through the perturbed poses, and averaged) or
//    "rotation fitted out" (the rotation between the perturbed and the nominal camera frame
//    that best aligns the covered area is removed, as cross-validation does).
//    Jacobians by central differences of camera_model.h's project(), so every model with
//    a fixed parameter count works; splined models are not supported (their
//    regularisation terms are part of mrcal's cost and are not modelled here).
//  - jackknife (empirical): the spread of the leave-one-view-out models around the full
//    one (rotation fitted out), var = (n-1)/n sum |d_i - mean d|^2 per pixel. It sees what
//    the linear model does not: per-view correlated detector errors and lens-model misfit.
//
// Both predict the cross-validation (odd/even halves compared, rotation fitted out):
// two independent half-models differ by sqrt(tr Cov_a + tr Cov_b) per pixel; with
// Cov_half ~ 2 Cov_full (half the views) that is 2 * sqrt(tr Cov_full).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "calib/board_detect.h"
#include "calib/camera_model.h"

namespace lp {

// One view as solved: board -> camera pose (Rodrigues r, t in board units) and its corners
// (row-major over the board) with the inlier flags the solve used.
struct SolvedView {
  std::array<double, 6> pose{};
  std::vector<std::array<double, 2>> px;
  std::vector<char> inlier;
};

// A regular grid of sample pixels and the standard deviation at each (NaN where the model
// has no ray). worst_px: along the worst direction (sqrt of the largest eigenvalue of the
// 2x2 covariance, as mrcal plots it); rms_px: sqrt(trace) (the 2-D RMS).
struct UncertaintyGrid {
  int nx = 0, ny = 0;
  std::vector<std::array<double, 2>> pixel;  // ny * nx row-major
  std::vector<double> worst_px, rms_px;
  // Summary of worst_px: at the grid point nearest the image centre, the median over the
  // grid points with a ray, and the worst of the four grid points nearest the image corners
  // (extrapolation for most calibrations: no board reaches there).
  double centre_px = 0, median_px = 0, corner_px = 0;
};

struct LinearCovariance {
  bool ok = false;
  std::string error;
  double sigma_px = 0;    // per-component residual sigma: sqrt(SSR / (2 corners - params))
  int intrinsics = 0;     // N; the parameters are N intrinsics, then 6 per view
  int params = 0;
  // params x params, row-major, sigma^2 (J^T J)^-1; with a fitted board warp, the marginal
  // block of the intrinsics and poses (the warp's uncertainty is in theirs).
  std::vector<double> covariance;
  // With a fitted board warp: its 2 x 2 covariance (mm^2, row-major; x2, y2 as BoardWarp).
  std::array<double, 4> warp_covariance{};
};

// Throws InputError for views whose corner count is not the board's. ok = false (with
// error) for splined models or a singular J^T J. warp: the board warp fitted with the
// model (a free parameter pair of the solve, after the poses), nullptr for a flat board
// that was not fitted.
LinearCovariance linearised_covariance(const CameraModel& model, const BoardSpec& board,
                                       const std::vector<SolvedView>& views, const BoardWarp* warp = nullptr);

// The pixels a grid of nx x ny cells covers (cell centres) over the model's image.
std::vector<std::array<double, 2>> grid_pixels(const CameraModel& model, int nx, int ny);

// Linearised uncertainty at `pixels` (grid given as nx x ny, or nx = pixels.size(), ny = 1
// for a list). fit_mask (width*height, nonzero = covered) is where the rotation is fitted
// for the rotation-fitted-out method; mean_frames needs the views' poses.
UncertaintyGrid linear_uncertainty_mean_frames(const LinearCovariance& cov, const CameraModel& model,
                                               const std::vector<SolvedView>& views,
                                               const std::vector<std::array<double, 2>>& pixels, int nx, int ny);
UncertaintyGrid linear_uncertainty_rotation_fitted(const LinearCovariance& cov, const CameraModel& model,
                                                   const std::vector<uint8_t>& fit_mask, int fit_step_px,
                                                   const std::vector<std::array<double, 2>>& pixels, int nx, int ny);

// Per-pixel difference vectors (px) of model b against model a at `pixels`: unproject with
// a, rotate by the rotation that best aligns a's rays with b's over the pixels of
// `fit_pixels` (identity when !fit_rotation), project with b, minus the pixel. NaN where
// a model has no ray.
std::vector<std::array<double, 2>> projection_difference_vectors(const CameraModel& a, const CameraModel& b,
                                                                 const std::vector<std::array<double, 2>>& fit_pixels,
                                                                 const std::vector<std::array<double, 2>>& pixels,
                                                                 bool fit_rotation = true);

// Jackknife uncertainty of `full` from its leave-one-view-out refits, rotation fitted over
// fit_pixels (the covered area), at `pixels` (an nx x ny grid); with at_fit, also at
// fit_pixels themselves (one row), from the same unprojection of each model there. The
// models are compared on every core (`parallel`); the grids are the same either way.
UncertaintyGrid jackknife_uncertainty(const CameraModel& full, const std::vector<CameraModel>& leave_one_out,
                                      const std::vector<std::array<double, 2>>& fit_pixels,
                                      const std::vector<std::array<double, 2>>& pixels, int nx, int ny,
                                      UncertaintyGrid* at_fit = nullptr, bool parallel = true);

// sqrt(mean over finite points of rms_px^2): the RMS 2-D projection spread over the points.
double rms_over(const UncertaintyGrid& g);

// Pixels of a row-major mask sampled every step px (as projection_difference samples them).
std::vector<std::array<double, 2>> mask_pixels(const std::vector<uint8_t>& mask, int width, int height, int step_px);

}  // namespace lp
