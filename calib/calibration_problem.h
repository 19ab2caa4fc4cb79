// What every stage of a geometric calibration shares (geometric.h composes the stages:
// calibration_seed.h, calibration_solve.h, outlier_rejection.h, model_selection.h,
// view_diagnostics.h, calibration_uncertainty.h): the views (detected corners with their
// inlier flags), board poses, a model fitted to a subset of the views, and the residual and
// pose helpers they all use.
//
// Board frame: inner corner k = r * cols + c at (c * square_mm, r * square_mm, z), z = 0 for a
// flat board, else the fit's board warp (BoardWarp, board_detect.h: mrcal's calobject_warp).
// Poses map board to camera (Rodrigues r, then t in mm). Pixels and camera frame as
// calib/camera_model.h.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "calib/board_detect.h"
#include "calib/camera_model.h"

namespace lp {

using BoardPose = std::array<double, 6>;  // board -> camera: Rodrigues r, t (mm)

struct BoardView {
  int index = 0;                           // view index as given to calibrate()
  std::vector<std::array<double, 2>> px;   // cols * rows corners, row-major
  std::vector<char> inlier;                // per corner: used by the fits
};
// Views a fit runs on (pointers into the calibration's views, which outlive it).
using ViewSubset = std::vector<const BoardView*>;

// A model fitted to a subset of views: intrinsics and one pose per view of the subset.
struct ModelFit {
  bool ok = false;
  std::string error;         // why not, when !ok
  CameraModel model;
  std::vector<BoardPose> poses;  // aligned with the subset it was fitted on
  int params = 0;            // free intrinsics
  std::string solver;        // how it was obtained, e.g. "cv::fisheye + Ceres"
  // The board's flex fitted with it (SolveOptions::board_warp; {0, 0}: flat, or not fitted,
  // as for OpenCV's own solutions, which warp_fitted tells apart).
  BoardWarp warp{};
  bool warp_fitted = false;
  int iterations = 0;  // the Ceres refinement's iterations (Kannala-Brandt, Mei); 0 otherwise
};

// What the solvers need to know beyond the corners.
struct SolveOptions {
  // false: OpenCV paths only (stereographic and splined models unavailable).
  bool use_mrcal = true;
  // The splined candidate: cubic, spline_nx x spline_ny control points, field of view from
  // its stereographic seed.
  int spline_order = 3, spline_nx = 8, spline_ny = 6;
  // Fit the board's flex (BoardWarp: mrcal's calobject_warp, two parameters) in every joint
  // solve, Ceres and mrcal alike. On by default, as mrcal-calibrate-cameras does: real
  // boards are not flat to a tenth of a pixel at close range, and the misfit of a flat
  // board model otherwise ends as outliers on the boards' outer rows (docs/calibration.md,
  // "Board warp"). OpenCV's closed-form seeds are flat.
  bool board_warp = true;
  // Mei's seed (calibration_seed.h): from the Kannala-Brandt fit of the same views where that
  // fits them within 1 px, else the unit-xi search (mei_unit_xi_seed). calibrate() with the
  // automatic choice decides it once, from Kannala-Brandt on the outlier stage's sample
  // (reject_outliers), so that every Mei fit of one calibration is seeded alike; false (the
  // unit-xi search only) for a requested model and any other caller.
  bool mei_from_kannala_brandt = false;
  // Mei is refined in the coordinates of its radial profile (f / (1 + xi), its theta^3 and
  // theta^5 coefficients, xi) where its seed sees every corner within this many degrees of
  // the axis. The same model and minimum; on a narrow field xi is barely observable and
  // Ceres walked the valley it makes in (f, xi, k1, k2) for ~80 iterations (Ladybug: 80 -> 28
  // a solve, the automatic choice 0.78x the wall time). On wide fields the profile
  // coordinates are the slower ones (fisheye1, corners to 84 deg: 1.28x; Fisheye190deg,
  // 69 deg: 37 -> 118 iterations a solve), hence 60, the selection's perspective_field_deg.
  // 0: never.
  double mei_profile_field_deg = 60;
  // Kannala-Brandt's Ceres refinement, from this iteration on, stops once 10 iterations
  // gained less than 1 % of the cost (0: runs to the cap of 200, as Mei's). Where it fits
  // the lens it converges in 5-9 (every shared set, synthetic 8-64 views of the 190 deg
  // lens); on a mirror it cannot fit, and the misfit crawled to the cap (230 ms on MiniOmni's
  // 15 views, on the reference choice's critical path, and twice more in the candidate
  // stage), 258198 px off at 65 iterations (where it stalls) and at 200. A crawl can end
  // somewhere better: on MiniOmni's 7-view sample Kannala-Brandt stalls at 8.3 px, and ran on
  // to 0.37 px at 104 iterations, a mirror's half it fits but cannot fit whole (11.2 px); it
  // is now screened out on the sample instead of on every view.
  int kannala_brandt_stall_after = 50;
};

struct CalibrationProblem {
  BoardSpec board;
  int width = 0, height = 0;
  SolveOptions solve;
  int diff_step_px = 0;  // grid step of projection differences; 0 = auto_step()
};

// Progress of a stage: (stage name, steps done, steps in the stage), from the calling thread.
using StageProgress = std::function<void(const std::string& stage, int done, int total)>;
void report_progress(const StageProgress& progress, const char* stage, size_t done, size_t total);

// The views with a board, every corner an inlier. `who` names the caller in the one-line
// InputErrors: a view with the wrong number of corners; with check_inside, a corner outside
// width x height (images of another resolution); fewer than 4 views with a board.
std::vector<BoardView> make_board_views(const std::vector<std::vector<std::array<double, 2>>>& corners_per_view,
                                        const CalibrationProblem& problem, const std::string& who,
                                        bool check_inside);
ViewSubset all_of(const std::vector<BoardView>& views);
// At most `count` of `views`, evenly spaced (view k * size / count): all of them when there
// are no more.
ViewSubset evenly_spaced(const ViewSubset& views, size_t count);

// Board-frame point of corner k (mm), on a board flexed by `warp`.
std::array<double, 3> board_point(const BoardSpec& board, int k, const BoardWarp& warp = {});
CameraModel make_model(const CalibrationProblem& problem, const std::string& lensmodel, std::vector<double> intrinsics);

// observed - projected per corner (every corner, inlier or not) of a board flexed by
// `warp`; NaN where the model cannot image the corner.
std::vector<std::array<double, 2>> view_residuals(const CalibrationProblem& problem, const CameraModel& model,
                                                  const BoardWarp& warp, const BoardView& view, const BoardPose& pose);
// Sum of squared inlier residuals of a view; a corner the model cannot image counts 1e12.
double view_squared_error(const CalibrationProblem& problem, const CameraModel& model, const BoardWarp& warp,
                          const BoardView& view, const BoardPose& pose);
// How far off the axis the boards were seen under `model`: the largest angle (deg) of an
// inlier corner's unprojected ray; 0 when none unprojects.
double corner_field_deg(const CameraModel& model, const ViewSubset& views);
// The angle off the axis (rad) of every inlier corner of `views`, where `fit`'s poses and
// board warp put it, view by view (views beyond fit.poses are left out): no unprojection.
std::vector<double> posed_corner_angles(const CalibrationProblem& problem, const ViewSubset& views,
                                        const ModelFit& fit);
// RMS (2-D) of a fit over the inliers of its subset; 1e6 px per corner it cannot image.
double fit_rms(const CalibrationProblem& problem, const ModelFit& fit, const ViewSubset& views);

// Board pose of a view under fixed intrinsics and board warp: PnP on the unprojected rays
// (in a frame turned towards the view's mean ray when some rays point sideways or
// backwards), then refined on pixels. nullopt when too few rays are usable.
std::optional<BoardPose> solve_pose(const CalibrationProblem& problem, const CameraModel& model,
                                    const BoardWarp& warp, const BoardView& view);
// RMS of the views' inlier corners under `fit`'s intrinsics and board warp with their poses
// re-solved; inf when some view cannot be posed.
double heldout_rms(const CalibrationProblem& problem, const ModelFit& fit, const ViewSubset& views);

// The area the boards covered: union of each view's convex hull of inlier corners
// (width * height, row-major, 255 inside).
std::vector<uint8_t> coverage_mask(const CalibrationProblem& problem, const ViewSubset& views);
// diff_step_px, or about 5000 samples over the image (at least every 2 px).
int auto_step(const CalibrationProblem& problem);

double rms_of(const std::vector<double>& squares);  // sqrt(mean); 0 for none
double median_of(std::vector<double> values);      // 0 for none; mean of the middle two

}  // namespace lp
