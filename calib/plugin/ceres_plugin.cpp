// The plugin of calib/ceres_plugin.h: the only code linked with Ceres. The cost functions
// moved here from calibration_solve.cpp and photometric.cpp unchanged, and each problem is
// built in the order those files built it, so that the solves are bit for bit the same;
// since stop 40 Mei's corner cost (MeiCornerCost) and since stop 41 Kannala-Brandt's
// (KannalaBrandtCornerCost) have hand-written Jacobians, the autodiff ones to rounding.
#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <glog/logging.h>

#include <cmath>
#include <type_traits>
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
// Mei in the coordinates of its radial profile. For a ray at theta off the axis Mei's
// undistorted radius is sin(theta) / (cos(theta) + xi) = theta / s (1 + A theta^2 +
// B theta^4 + ...), s = 1 + xi, A = 1 / (2 s) - 1/6, B = 1 / (4 s^2) - 1 / (8 s) + 1/120, and
// with k1, k2 the distorted one is theta / s (1 + c3 theta^2 + c5 theta^4 + ...), c3 = A + k1
// / s^2, c5 = B + 3 A k1 / s^2 + k2 / s^4. On a narrow field the corners pin g = f / s, c3 and
// c5, not xi: in (fx, fy, xi, k1, k2) that is a curved valley that Ceres walked for ~80
// iterations on Ladybug. Solved in (gx, gy, cx, cy, xi, c3, c5, p1, p2) instead, xi alone
// moves only the theta^7 terms: 28. The map is one to one for s > 0; the same model.
struct MeiProfileProjection {
  static constexpr int kParams = 9;
  // A(s) and B(s) above.
  template <typename T>
  static T a_of(const T& s) {
    return T(1) / (T(2) * s) - T(1.0 / 6);
  }
  template <typename T>
  static T b_of(const T& s) {
    return T(1) / (T(4) * s * s) - T(1) / (T(8) * s) + T(1.0 / 120);
  }
  template <typename T>
  static void to_mei(const T* u, T* in) {
    const T s = T(1) + u[4], s2 = s * s, a = a_of(s), b = b_of(s);
    in[0] = u[0] * s, in[1] = u[1] * s, in[2] = u[2], in[3] = u[3], in[4] = u[4];
    in[5] = (u[5] - a) * s2;
    in[6] = (u[6] - b - T(3) * a * (u[5] - a)) * s2 * s2;
    in[7] = u[7], in[8] = u[8];
  }
  static void from_mei(const double* in, double* u) {
    const double s = 1 + in[4], s2 = s * s, a = a_of(s), b = b_of(s);
    u[0] = in[0] / s, u[1] = in[1] / s, u[2] = in[2], u[3] = in[3], u[4] = in[4];
    u[5] = a + in[5] / s2;
    u[6] = b + 3 * a * in[5] / s2 + in[6] / (s2 * s2);
    u[7] = in[7], u[8] = in[8];
  }
  template <typename T>
  static void project(const T* u, const T* C, T* q) {
    T in[9];
    to_mei(u, in);
    MeiProjection::project(in, C, q);
  }
};
static_assert(KannalaBrandtProjection::kParams == kCeresProjectionParams[0] &&
              MeiProjection::kParams == kCeresProjectionParams[1] &&
              MeiProfileProjection::kParams == kCeresProjectionParams[2]);

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

// The board point (X, Y) lifted by the warp, rotated and translated by the pose, with the
// rotation's derivatives by autodiff in 4 dimensions (the angle-axis and the point's z, which
// the warp moves): what the hand-written corner costs below share.
struct PosedPoint {
  ceres::Jet<double, 4> Cj[3];
  double C[3];
  PosedPoint(double X, double Y, double dx, double dy, const double* pose, const double* warp) {
    using J4 = ceres::Jet<double, 4>;
    const J4 r[3] = {J4(pose[0], 0), J4(pose[1], 1), J4(pose[2], 2)};
    const J4 P[3] = {J4(X), J4(Y), J4(warp[0] * dx + warp[1] * dy, 3)};
    ceres::AngleAxisRotatePoint(r, P, Cj);
    C[0] = Cj[0].a + pose[3], C[1] = Cj[1].a + pose[4], C[2] = Cj[2].a + pose[5];
  }
  // The pose's (2 x 6: angle-axis, translation) and the warp's (2 x 2) Jacobians from the
  // residual's derivative dq/dC; a null block is skipped.
  void chain(const double (&dq)[2][3], double dx, double dy, double* J_pose, double* J_warp) const {
    if (J_pose)
      for (int i = 0; i < 2; ++i) {
        for (int k = 0; k < 3; ++k)
          J_pose[6 * i + k] = dq[i][0] * Cj[0].v[k] + dq[i][1] * Cj[1].v[k] + dq[i][2] * Cj[2].v[k];
        for (int k = 0; k < 3; ++k) J_pose[6 * i + 3 + k] = dq[i][k];
      }
    if (J_warp)
      for (int i = 0; i < 2; ++i) {
        const double dz = dq[i][0] * Cj[0].v[3] + dq[i][1] * Cj[1].v[3] + dq[i][2] * Cj[2].v[3];
        J_warp[2 * i] = dz * dx;
        J_warp[2 * i + 1] = dz * dy;
      }
  }
};

// One corner's observation for a cost with hand-written Jacobians: N intrinsics, the pose,
// the warp (as CornerCost).
template <int N>
struct HandWrittenCornerCost : ceres::SizedCostFunction<2, N, 6, 2> {
  double X, Y, dx, dy, qx, qy;
  HandWrittenCornerCost(double X_, double Y_, double dx_, double dy_, double qx_, double qy_)
      : X(X_), Y(Y_), dx(dx_), dy(dy_), qx(qx_), qy(qy_) {}
};

// CornerCost<MeiProjection> with its Jacobians written out: the rotation of the lifted board
// point by autodiff in 4 dimensions (the angle-axis r and the point's z, which the warp
// moves), the rest of the chain (translation, Mei's lift and distortion, the warp's two
// factors) by hand. Autodiff in all 17 (9 intrinsics, 6 pose, 2 warp) was the largest
// cost of Mei's solves (perf, Ladybug: its derivative code 15 % of the automatic choice's
// CPU, its warm refits walking ~80 iterations along the xi valley). The same residual and
// derivatives to rounding (jacobian_mismatch, tested against the autodiff form).
struct MeiCornerCost final : HandWrittenCornerCost<9> {
  using HandWrittenCornerCost::HandWrittenCornerCost;
  bool Evaluate(const double* const* parameters, double* residuals, double** jacobians) const override {
    const double* in = parameters[0];
    const PosedPoint posed(X, Y, dx, dy, parameters[1], parameters[2]);
    const double* C = posed.C;
    const double xi = in[4], k1 = in[5], k2 = in[6], p1 = in[7], p2 = in[8];
    // Lift: xu = C0 / m, yu = C1 / m with m = C2 + xi |C| (= |C| (C2 / |C| + xi)).
    const double n = std::sqrt(C[0] * C[0] + C[1] * C[1] + C[2] * C[2]);
    const double m = C[2] + xi * n;
    const double xu = C[0] / m, yu = C[1] / m;
    const double r2 = xu * xu + yu * yu;
    const double radial = 1 + k1 * r2 + k2 * r2 * r2;
    const double xd = xu * radial + 2 * p1 * xu * yu + p2 * (r2 + 2 * xu * xu);
    const double yd = yu * radial + p1 * (r2 + 2 * yu * yu) + 2 * p2 * xu * yu;
    residuals[0] = in[0] * xd + in[2] - qx;
    residuals[1] = in[1] * yd + in[3] - qy;
    if (!jacobians) return true;
    // d(xd, yd) / d(xu, yu)
    const double dradial = 2 * k1 + 4 * k2 * r2;  // 2 d radial / d r2
    const double j00 = radial + xu * dradial * xu + 2 * p1 * yu + 6 * p2 * xu;
    const double j01 = xu * dradial * yu + 2 * p1 * xu + 2 * p2 * yu;
    const double j10 = yu * dradial * xu + 2 * p1 * xu + 2 * p2 * yu;
    const double j11 = radial + yu * dradial * yu + 6 * p1 * yu + 2 * p2 * xu;
    // d(xu, yu) / dC and / dxi
    const double dm[3] = {xi * C[0] / n, xi * C[1] / n, 1 + xi * C[2] / n};
    double dxu[3], dyu[3];
    for (int k = 0; k < 3; ++k) {
      dxu[k] = ((k == 0 ? 1.0 : 0.0) - xu * dm[k]) / m;
      dyu[k] = ((k == 1 ? 1.0 : 0.0) - yu * dm[k]) / m;
    }
    const double dxu_dxi = -xu * n / m, dyu_dxi = -yu * n / m;
    // dq / dC
    double dq[2][3];
    for (int k = 0; k < 3; ++k) {
      dq[0][k] = in[0] * (j00 * dxu[k] + j01 * dyu[k]);
      dq[1][k] = in[1] * (j10 * dxu[k] + j11 * dyu[k]);
    }
    if (double* J = jacobians[0]) {  // 2 x 9: fx fy cx cy xi k1 k2 p1 p2
      J[0] = xd, J[1] = 0, J[2] = 1, J[3] = 0;
      J[4] = in[0] * (j00 * dxu_dxi + j01 * dyu_dxi);
      J[5] = in[0] * xu * r2, J[6] = in[0] * xu * r2 * r2;
      J[7] = in[0] * 2 * xu * yu, J[8] = in[0] * (r2 + 2 * xu * xu);
      J[9] = 0, J[10] = yd, J[11] = 0, J[12] = 1;
      J[13] = in[1] * (j10 * dxu_dxi + j11 * dyu_dxi);
      J[14] = in[1] * yu * r2, J[15] = in[1] * yu * r2 * r2;
      J[16] = in[1] * (r2 + 2 * yu * yu), J[17] = in[1] * 2 * xu * yu;
    }
    posed.chain(dq, dx, dy, jacobians[1], jacobians[2]);
    return true;
  }
};

// CornerCost<MeiProfileProjection>: MeiCornerCost at the profile coordinates' Mei
// intrinsics, its intrinsics' Jacobian carried to the profile coordinates by the chain rule.
struct MeiProfileCornerCost final : HandWrittenCornerCost<9> {
  MeiCornerCost mei;
  MeiProfileCornerCost(double X_, double Y_, double dx_, double dy_, double qx_, double qy_)
      : HandWrittenCornerCost(X_, Y_, dx_, dy_, qx_, qy_), mei(X_, Y_, dx_, dy_, qx_, qy_) {}
  bool Evaluate(const double* const* parameters, double* residuals, double** jacobians) const override {
    const double* u = parameters[0];
    double in[9], J_mei[18];
    MeiProfileProjection::to_mei(u, in);
    const double* mei_parameters[3] = {in, parameters[1], parameters[2]};
    double* mei_jacobians[3] = {nullptr, nullptr, nullptr};
    if (jacobians) mei_jacobians[0] = jacobians[0] ? J_mei : nullptr, mei_jacobians[1] = jacobians[1], mei_jacobians[2] = jacobians[2];
    if (!mei.Evaluate(mei_parameters, residuals, jacobians ? mei_jacobians : nullptr)) return false;
    if (!jacobians || !jacobians[0]) return true;
    // d(fx, fy, k1, k2) / d(gx, gy, xi, c3, c5); cx, cy, p1, p2 are the same.
    const double s = 1 + u[4], s2 = s * s, s3 = s2 * s, s4 = s2 * s2;
    const double a = MeiProfileProjection::a_of(s), b = MeiProfileProjection::b_of(s);
    const double da = -1 / (2 * s2), db = -1 / (2 * s3) + 1 / (8 * s2);
    const double dk1_dxi = -da * s2 + 2 * (u[5] - a) * s;
    const double k2_core = u[6] - b - 3 * a * (u[5] - a);
    const double dk2_dxi = (-db - 3 * da * u[5] + 6 * a * da) * s4 + 4 * k2_core * s3;
    for (int i = 0; i < 2; ++i) {
      const double* m = J_mei + 9 * i;
      double* J = jacobians[0] + 9 * i;
      J[0] = m[0] * s, J[1] = m[1] * s, J[2] = m[2], J[3] = m[3];
      J[4] = m[4] + m[0] * u[0] + m[1] * u[1] + m[5] * dk1_dxi + m[6] * dk2_dxi;
      J[5] = m[5] * s2 - m[6] * 3 * a * s4;
      J[6] = m[6] * s4;
      J[7] = m[7], J[8] = m[8];
    }
    return true;
  }
};

// CornerCost<KannalaBrandtProjection> with its Jacobians written out, as MeiCornerCost: the
// rotation by autodiff in 4 dimensions, the rest by hand. Autodiff in all 16 (8 intrinsics,
// 6 pose, 2 warp) was ~30 % of a forced 64-view calibration's CPU (perf: its Jet arithmetic,
// the rotation and atan2 of Jets), which is mostly Kannala-Brandt's leave-one-out refits. The
// same residual and derivatives to rounding (jacobian_mismatch, tested against the autodiff
// form).
struct KannalaBrandtCornerCost final : HandWrittenCornerCost<8> {
  using HandWrittenCornerCost::HandWrittenCornerCost;
  bool Evaluate(const double* const* parameters, double* residuals, double** jacobians) const override {
    const double* in = parameters[0];
    const PosedPoint posed(X, Y, dx, dy, parameters[1], parameters[2]);
    const double* C = posed.C;
    // s = d(theta) / rho, d = theta (1 + k1 t2 + ... + k4 t2^4), t2 = theta^2; q = f s C + c.
    // ds: d s / d C; dsk: d s / d k1..k4.
    const double rho2 = C[0] * C[0] + C[1] * C[1];
    double s, ds[3], dsk[4];
    if (rho2 < 1e-24) {  // on the axis, as KannalaBrandtProjection
      s = 1 / C[2];
      ds[0] = ds[1] = 0;
      ds[2] = -s / C[2];
      dsk[0] = dsk[1] = dsk[2] = dsk[3] = 0;
    } else {
      const double rho = std::sqrt(rho2);
      const double th = std::atan2(rho, C[2]);
      const double t2 = th * th;
      const double poly = 1 + t2 * (in[4] + t2 * (in[5] + t2 * (in[6] + t2 * in[7])));
      s = th * poly / rho;
      const double dd_dth = poly + 2 * t2 * (in[4] + t2 * (2 * in[5] + t2 * (3 * in[6] + t2 * 4 * in[7])));
      const double den = rho2 + C[2] * C[2];
      const double ds_drho = (dd_dth * C[2] / den - s) / rho;  // (dd/drho - s) / rho
      ds[0] = ds_drho * C[0] / rho;
      ds[1] = ds_drho * C[1] / rho;
      ds[2] = -dd_dth / den;  // dd/dth * dth/dC2 / rho, dth/dC2 = -rho / den
      double tk = th / rho;
      for (double& d : dsk) d = tk *= t2;  // theta^(2i + 3) / rho
    }
    residuals[0] = in[0] * s * C[0] + in[2] - qx;
    residuals[1] = in[1] * s * C[1] + in[3] - qy;
    if (!jacobians) return true;
    double dq[2][3];  // dq / dC
    for (int k = 0; k < 3; ++k) {
      dq[0][k] = in[0] * ((k == 0 ? s : 0.0) + C[0] * ds[k]);
      dq[1][k] = in[1] * ((k == 1 ? s : 0.0) + C[1] * ds[k]);
    }
    if (double* J = jacobians[0]) {  // 2 x 8: fx fy cx cy k1 k2 k3 k4
      J[0] = s * C[0], J[1] = 0, J[2] = 1, J[3] = 0;
      J[8] = 0, J[9] = s * C[1], J[10] = 0, J[11] = 1;
      for (int i = 0; i < 4; ++i) {
        J[4 + i] = in[0] * C[0] * dsk[i];
        J[12 + i] = in[1] * C[1] * dsk[i];
      }
    }
    posed.chain(dq, dx, dy, jacobians[1], jacobians[2]);
    return true;
  }
};

template <class Projection>
ceres::CostFunction* corner_cost(const CeresCorner& k) {
  using Cost = CornerCost<Projection>;
  return new ceres::AutoDiffCostFunction<Cost, 2, Projection::kParams, 6, 2>(
      new Cost{k.X, k.Y, k.dx, k.dy, k.qx, k.qy});
}
template <>
ceres::CostFunction* corner_cost<MeiProjection>(const CeresCorner& k) {
  return new MeiCornerCost(k.X, k.Y, k.dx, k.dy, k.qx, k.qy);
}
template <>
ceres::CostFunction* corner_cost<MeiProfileProjection>(const CeresCorner& k) {
  return new MeiProfileCornerCost(k.X, k.Y, k.dx, k.dy, k.qx, k.qy);
}
template <>
ceres::CostFunction* corner_cost<KannalaBrandtProjection>(const CeresCorner& k) {
  return new KannalaBrandtCornerCost(k.X, k.Y, k.dx, k.dy, k.qx, k.qy);
}

template <class Projection>
CeresSolveSummary solve_joint_with(const CeresJointSolve& jp) {
  ceres::Problem problem;
  // The profile coordinates are solved in a block of their own, from Mei's and back.
  constexpr bool profile = std::is_same_v<Projection, MeiProfileProjection>;
  double profile_block[MeiProfileProjection::kParams];
  double* intrinsics = jp.intrinsics;
  if constexpr (profile) {
    MeiProfileProjection::from_mei(jp.intrinsics, profile_block);
    intrinsics = profile_block;
  }
  for (size_t c = 0; c < jp.corner_count; ++c) {
    const CeresCorner& k = jp.corners[c];
    problem.AddResidualBlock(corner_cost<Projection>(k), nullptr, intrinsics, jp.poses[k.view], jp.warp);
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
  // CeresJointSolve::stall_after: the cost of every iteration so far, and a stop once the
  // last 10 gained less than 1 % after that many.
  struct StallStop : ceres::IterationCallback {
    int after = 0;
    std::vector<double> costs;
    ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
      costs.push_back(s.cost);
      const size_t n = costs.size();
      if (after > 0 && n > size_t(after) && n > 10 && costs[n - 1] > 0.99 * costs[n - 11])
        return ceres::SOLVER_TERMINATE_SUCCESSFULLY;
      return ceres::SOLVER_CONTINUE;
    }
  } stall;
  stall.after = jp.stall_after;
  if (jp.stall_after > 0) o.callbacks.push_back(&stall);
  ceres::Solver::Summary summary;
  ceres::Solve(o, &problem, &summary);
  if constexpr (profile) MeiProfileProjection::to_mei(profile_block, jp.intrinsics);
  return {summary.IsSolutionUsable(), summary.initial_cost, summary.final_cost, int(summary.iterations.size())};
}

CeresSolveSummary solve_joint(const CeresJointSolve& jp) {
  switch (jp.projection) {
    case CeresProjection::Mei: return solve_joint_with<MeiProjection>(jp);
    case CeresProjection::MeiProfile: return solve_joint_with<MeiProfileProjection>(jp);
    default: return solve_joint_with<KannalaBrandtProjection>(jp);
  }
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

// The largest difference between Analytic's and the autodiff form's residual and Jacobians,
// relative to the larger of 1 and the largest autodiff entry.
template <class Projection, class Analytic>
double jacobian_mismatch_of(const double* in, const double* pose, const double* warp, const CeresCorner& k) {
  constexpr int n = Projection::kParams;
  const Analytic analytic(k.X, k.Y, k.dx, k.dy, k.qx, k.qy);
  const ceres::AutoDiffCostFunction<CornerCost<Projection>, 2, n, 6, 2> autodiff(
      new CornerCost<Projection>{k.X, k.Y, k.dx, k.dy, k.qx, k.qy});
  const double* params[3] = {in, pose, warp};
  double ra[2], rb[2], Ja[3][2 * n], Jb[3][2 * n];
  double* ja[3] = {Ja[0], Ja[1], Ja[2]};
  double* jb[3] = {Jb[0], Jb[1], Jb[2]};
  if (!analytic.Evaluate(params, ra, ja) || !autodiff.Evaluate(params, rb, jb)) return HUGE_VAL;
  const int sizes[3] = {2 * n, 12, 4};
  double scale = 1, diff = std::max(std::abs(ra[0] - rb[0]), std::abs(ra[1] - rb[1]));
  for (int b = 0; b < 3; ++b)
    for (int i = 0; i < sizes[b]; ++i) {
      scale = std::max(scale, std::abs(Jb[b][i]));
      diff = std::max(diff, std::abs(Ja[b][i] - Jb[b][i]));
    }
  return std::isfinite(diff) ? diff / scale : HUGE_VAL;
}

double jacobian_mismatch(CeresProjection projection, const double* in, const double* pose, const double* warp,
                         const CeresCorner& k) {
  switch (projection) {
    case CeresProjection::Mei: return jacobian_mismatch_of<MeiProjection, MeiCornerCost>(in, pose, warp, k);
    case CeresProjection::MeiProfile:
      return jacobian_mismatch_of<MeiProfileProjection, MeiProfileCornerCost>(in, pose, warp, k);
    default: return jacobian_mismatch_of<KannalaBrandtProjection, KannalaBrandtCornerCost>(in, pose, warp, k);
  }
}

constexpr CeresPluginTable kTable{kCeresPluginVersion, &solve_joint, &fit_photometric, &jacobian_mismatch};

}  // namespace
}  // namespace lp::detail

// Ceres reports a step it could not take (a singular system on a few views, where the solve
// then ends and its result says so) as a glog WARNING on stderr: 6-11 lines on a calibration of
// 5 of Ladybug's views. The library prints nothing of its own; errors still show.
extern "C" __attribute__((visibility("default"))) const void* lightprobe_ceres() {
  static const bool quiet = [] {
    FLAGS_minloglevel = google::GLOG_ERROR;
    return true;
  }();
  (void)quiet;
  return &lp::detail::kTable;
}
