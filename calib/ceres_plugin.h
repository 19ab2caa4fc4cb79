// Ceres, loaded on first use. libceres links glog, gflags, libunwind, SuiteSparse (CHOLMOD,
// SPQR, CXSparse, METIS and five ordering libraries) and LAPACK/BLAS: 17 shared libraries
// and ~7 ms that every command, even `--version`, paid at start, though only the Kannala-
// Brandt and Mei solves of calib/calibration_solve.cpp and the photometric fit of
// calib/photometric.cpp call Ceres. Those two problems live in a plugin instead
// (liblightprobe_ceres.so, calib/plugin/), which the first solve loads; it is found where
// core/lazy_libs.h looks for its plugin.
//
// The interface is plain data: the plugin holds the cost functions and the solver options,
// the callers keep the problems' meaning (seeds, fallbacks, reports). The parameters are
// solved in place in the caller's memory, in the order the callers built the problems
// before the split, so that the results are bit for bit what they were (Mei's since stop 40
// to rounding only: its corner residual's Jacobians are written out, not autodiffed).
//
// Internal to calib/: only calibration_solve.cpp, photometric.cpp and the plugin include it.
#pragma once

#include <cstddef>
#include <string>

namespace lp::detail {

// One board corner of a joint solve: board point (X, Y), its parabola factors (dx, dy) of
// the board warp (calibration_problem.h board_warp_z), the observed pixel (qx, qy), and the
// view whose pose it goes through.
struct CeresCorner {
  double X, Y, dx, dy, qx, qy;
  size_t view;
};

// MeiProfile is Mei solved in the coordinates of its radial profile (the plugin's
// MeiProfileProjection): the same model and minimum, its intrinsics given and returned as
// Mei's, for narrow fields, where Mei's focal length, xi, k1 and k2 lie along one curved
// valley (calibration_solve.cpp, refine_mei).
enum class CeresProjection : int { KannalaBrandt = 0, Mei = 1, MeiProfile = 2 };
// Parameters of each projection (the plugin's KannalaBrandtProjection, MeiProjection,
// MeiProfileProjection).
inline constexpr int kCeresProjectionParams[3] = {8, 9, 9};

struct CeresJointSolve {
  CeresProjection projection = CeresProjection::KannalaBrandt;
  const CeresCorner* corners = nullptr;
  size_t corner_count = 0;
  double* intrinsics = nullptr;  // kCeresProjectionParams[projection] values, solved in place
  double* const* poses = nullptr;  // one Rodrigues r, t (6 values) per view, solved in place
  double* warp = nullptr;          // the board warp {x2, y2}, solved in place when fit_warp
  bool fit_warp = false;
  // From this iteration on (0: never), the solve stops when the cost fell by less than 1 %
  // over the last 10 iterations: a fit that has converged that far, or one crawling towards
  // a misfit (SolveOptions::kannala_brandt_stall_after).
  int stall_after = 0;
};
struct CeresSolveSummary {
  bool usable = false;  // ceres::Solver::Summary::IsSolutionUsable()
  double initial_cost = 0, final_cost = 0;
  int iterations = 0;   // the solver's iterations
};

// The photometric fit (photometric.h): the robust least squares of one (linear: r = theta +
// a - b) or two (log sensor: r = (a - p0) / p1 - b) parameters over n readings.
struct CeresPhotometricFit {
  bool log_sensor = false;
  int loss = 0;  // 0 none, 1 Huber, 2 Cauchy (photometric.h RobustLoss)
  double loss_scale = 0;
  const double* a = nullptr;  // per reading: ln camera (linear) or the camera value (log sensor)
  const double* b = nullptr;  // per reading: ln measured
  size_t count = 0;
  double* params = nullptr;   // 1 (linear) or 2 (log sensor) values, solved in place from the start given
  bool with_covariance = false;
  double* covariance = nullptr;  // p x p, row-major, written when covariance_ok
};
struct CeresPhotometricSummary {
  bool usable = false;  // IsSolutionUsable() and every parameter finite
  double final_cost = 0;
  bool covariance_ok = false;
  std::string brief_report;  // ceres::Solver::Summary::BriefReport()
};

// What the plugin exports (its one symbol, `lightprobe_ceres`, returns it). The version
// changes whenever the table or the structs above do.
struct CeresPluginTable {
  int version;
  CeresSolveSummary (*solve_joint)(const CeresJointSolve& problem);
  CeresPhotometricSummary (*fit_photometric)(const CeresPhotometricFit& problem);
  // The largest difference between a corner residual's hand-written Jacobians (the
  // solver's, for each projection) and Ceres' autodiff of the same expression, at one
  // corner and parameter set (kCeresProjectionParams intrinsics, in the projection's own
  // coordinates), relative to the larger of 1 and the largest autodiff entry: for the
  // plugin's tests.
  double (*jacobian_mismatch)(CeresProjection projection, const double* intrinsics, const double* pose,
                              const double* warp, const CeresCorner& corner);
};
inline constexpr int kCeresPluginVersion = 5;
inline constexpr const char* kCeresPluginFile = "liblightprobe_ceres.so";

// The plugin's table, loaded once; throws std::runtime_error when it cannot be loaded.
const CeresPluginTable& ceres_plugin();

}  // namespace lp::detail
