// The plugin of calib/ceres_plugin.h: the only code linked with Ceres. The cost functions
// moved here from calibration_solve.cpp and photometric.cpp unchanged, and each problem is
// built in the order those files built it, so that the solves are bit for bit the same.
#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <cmath>
#include <vector>

#include "calib/ceres_plugin.h"

namespace lp::detail {
namespace {

// Kannala-Brandt projection of a camera-frame point (the projection of camera_model.cpp:
// theta from atan2, so rays beyond 90 deg work, unlike cv::fisheye).
struct KannalaBrandtProjection {
  static constexpr int kParams = 8;
  template <typename T>
  static void project(const T* in, const T* C, T* q) {
    const T rho2 = C[0] * C[0] + C[1] * C[1];
    T s;
    if (rho2 < T(1e-24)) {
      s = T(1) / C[2];
    } else {
      const T rho = ceres::sqrt(rho2);
      const T th = ceres::atan2(rho, C[2]);
      const T t2 = th * th;
      s = th * (T(1) + t2 * (in[4] + t2 * (in[5] + t2 * (in[6] + t2 * in[7])))) / rho;
    }
    q[0] = in[0] * s * C[0] + in[2];
    q[1] = in[1] * s * C[1] + in[3];
  }
};

// Mei projection, as camera_model.cpp: the point on the unit sphere, projected from
// (0, 0, -xi), radial-tangential distortion (k1 k2 p1 p2), no skew.
struct MeiProjection {
  static constexpr int kParams = 9;
  template <typename T>
  static void project(const T* in, const T* C, T* q) {
    const T n = ceres::sqrt(C[0] * C[0] + C[1] * C[1] + C[2] * C[2]);
    const T w = C[2] / n + in[4];
    const T xu = C[0] / n / w, yu = C[1] / n / w;
    const T r2 = xu * xu + yu * yu;
    const T radial = T(1) + in[5] * r2 + in[6] * r2 * r2;
    const T xd = xu * radial + T(2) * in[7] * xu * yu + in[8] * (r2 + T(2) * xu * xu);
    const T yd = yu * radial + in[7] * (r2 + T(2) * yu * yu) + T(2) * in[8] * xu * yu;
    q[0] = in[0] * xd + in[2];
    q[1] = in[1] * yd + in[3];
  }
};
static_assert(KannalaBrandtProjection::kParams == kCeresProjectionParams[0] &&
              MeiProjection::kParams == kCeresProjectionParams[1]);

// Reprojection residual of one corner: board point (X, Y) lifted by the board warp
// (mrcal's flex: z = x2 * dx + y2 * dy, dx and dy the corner's parabola factors,
// board_warp_z), then the pose, then Projection; minus the observed pixel (qx, qy).
template <class Projection>
struct CornerCost {
  double X, Y, dx, dy, qx, qy;
  template <typename T>
  bool operator()(const T* in, const T* pose, const T* warp, T* r) const {
    const T P[3] = {T(X), T(Y), warp[0] * dx + warp[1] * dy};
    T C[3];
    ceres::AngleAxisRotatePoint(pose, P, C);
    C[0] += pose[3];
    C[1] += pose[4];
    C[2] += pose[5];
    Projection::project(in, C, r);
    r[0] -= T(qx);
    r[1] -= T(qy);
    return true;
  }
};

template <class Projection>
CeresSolveSummary solve_joint_with(const CeresJointSolve& jp) {
  ceres::Problem problem;
  for (size_t c = 0; c < jp.corner_count; ++c) {
    const CeresCorner& k = jp.corners[c];
    using Cost = CornerCost<Projection>;
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<Cost, 2, Projection::kParams, 6, 2>(new Cost{k.X, k.Y, k.dx, k.dy, k.qx, k.qy}),
        nullptr, jp.intrinsics, jp.poses[k.view], jp.warp);
  }
  if (!jp.fit_warp) problem.SetParameterBlockConstant(jp.warp);
  ceres::Solver::Options o;
  o.linear_solver_type = ceres::DENSE_SCHUR;
  o.num_threads = 1;
  o.max_num_iterations = 200;
  // Converged when the cost changes by < 1e-12 (relative) or a step moves the parameters
  // by < 1e-10 (relative): corners are good to ~0.1 px, and at these tolerances the
  // projection agrees with a solve run to 1e-16 within 1e-7 px on the real sets, while
  // 1e-16 kept iterating on rounding noise (10-20 iterations with no change of the cost).
  o.function_tolerance = 1e-12;
  o.gradient_tolerance = 1e-10;
  o.parameter_tolerance = 1e-10;
  o.logging_type = ceres::SILENT;
  o.minimizer_progress_to_stdout = false;
  ceres::Solver::Summary summary;
  ceres::Solve(o, &problem, &summary);
  return {summary.IsSolutionUsable(), summary.initial_cost, summary.final_cost};
}

CeresSolveSummary solve_joint(const CeresJointSolve& jp) {
  return jp.projection == CeresProjection::Mei ? solve_joint_with<MeiProjection>(jp)
                                               : solve_joint_with<KannalaBrandtProjection>(jp);
}

ceres::LossFunction* make_loss(int loss, double scale) {
  switch (loss) {
    case 1: return new ceres::HuberLoss(scale);
    case 2: return new ceres::CauchyLoss(scale);
    default: return nullptr;
  }
}

// r = theta + ln(camera) - ln(measured), theta = ln k.
struct LinearCost {
  double log_camera, log_measured;
  template <typename T>
  bool operator()(const T* theta, T* residual) const {
    residual[0] = theta[0] + T(log_camera) - T(log_measured);
    return true;
  }
};

// r = (v - a) / b - ln(measured), ab = {a, b}.
struct LogSensorCost {
  double value, log_measured;
  template <typename T>
  bool operator()(const T* ab, T* residual) const {
    residual[0] = (T(value) - ab[0]) / ab[1] - T(log_measured);
    return true;
  }
};

CeresPhotometricSummary fit_photometric(const CeresPhotometricFit& fp) {
  ceres::Problem problem;
  double* params = fp.params;
  for (size_t i = 0; i < fp.count; ++i) {
    if (!fp.log_sensor) {
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<LinearCost, 1, 1>(new LinearCost{fp.a[i], fp.b[i]}),
                               make_loss(fp.loss, fp.loss_scale), params);
    } else {
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<LogSensorCost, 1, 2>(new LogSensorCost{fp.a[i], fp.b[i]}),
                               make_loss(fp.loss, fp.loss_scale), params);
    }
  }
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::DENSE_QR;
  solver.logging_type = ceres::SILENT;
  solver.minimizer_progress_to_stdout = false;
  solver.max_num_iterations = 200;
  solver.function_tolerance = 1e-16;
  solver.gradient_tolerance = 1e-16;
  solver.parameter_tolerance = 1e-16;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  CeresPhotometricSummary out;
  out.usable = summary.IsSolutionUsable();
  out.final_cost = summary.final_cost;
  out.brief_report = summary.BriefReport();
  const size_t p = fp.log_sensor ? 2 : 1;
  for (size_t k = 0; k < p; ++k) out.usable = out.usable && std::isfinite(params[k]);
  if (out.usable && fp.with_covariance) {
    ceres::Covariance::Options cov_options;
    cov_options.algorithm_type = ceres::DENSE_SVD;
    cov_options.null_space_rank = -1;  // pseudo-inverse: never fails on a flat direction
    ceres::Covariance covariance(cov_options);
    std::vector<std::pair<const double*, const double*>> blocks{{params, params}};
    out.covariance_ok = covariance.Compute(blocks, &problem) && covariance.GetCovarianceBlock(params, params, fp.covariance);
  }
  return out;
}

constexpr CeresPluginTable kTable{kCeresPluginVersion, &solve_joint, &fit_photometric};

}  // namespace
}  // namespace lp::detail

extern "C" __attribute__((visibility("default"))) const void* lightprobe_ceres() { return &lp::detail::kTable; }
