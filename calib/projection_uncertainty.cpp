#include "calib/projection_uncertainty.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "calib/lens_model.h"
#include "calib/parallel_jobs.h"
#include "core/error.h"

namespace lp {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

Eigen::Matrix3d rotation_of(const double* r) {
  const Eigen::Vector3d v(r[0], r[1], r[2]);
  const double a = v.norm();
  if (a < 1e-300) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(a, v / a).toRotationMatrix();
}

std::optional<Eigen::Vector2d> proj(const CameraModel& m, const Eigen::Vector3d& p) {
  const auto q = project(m, {p[0], p[1], p[2]});
  if (!q) return std::nullopt;
  return Eigen::Vector2d(q->x, q->y);
}

double step_for(double x) { return 1e-6 * std::max(1.0, std::abs(x)); }

// d project / d intrinsics (2 x N) at camera point p; false where a perturbed model cannot image p.
bool intrinsics_jacobian(const CameraModel& m, const Eigen::Vector3d& p, Eigen::MatrixXd& G) {
  const int n = int(m.intrinsics.size());
  G.resize(2, n);
  CameraModel t = m;
  for (int j = 0; j < n; ++j) {
    const double h = step_for(m.intrinsics[j]);
    t.intrinsics[j] = m.intrinsics[j] + h;
    const auto a = proj(t, p);
    t.intrinsics[j] = m.intrinsics[j] - h;
    const auto b = proj(t, p);
    t.intrinsics[j] = m.intrinsics[j];
    if (!a || !b) return false;
    G.col(j) = (*a - *b) / (2 * h);
  }
  return true;
}

// d project / d p (2 x 3) at camera point p.
bool point_jacobian(const CameraModel& m, const Eigen::Vector3d& p, Eigen::Matrix<double, 2, 3>& J) {
  const double h = 1e-6 * std::max(1.0, p.norm());
  for (int k = 0; k < 3; ++k) {
    Eigen::Vector3d a = p, b = p;
    a[k] += h;
    b[k] -= h;
    const auto qa = proj(m, a), qb = proj(m, b);
    if (!qa || !qb) return false;
    J.col(k) = (*qa - *qb) / (2 * h);
  }
  return true;
}

Eigen::Matrix3d cross_matrix(const Eigen::Vector3d& v) {
  Eigen::Matrix3d c;
  c << 0, -v[2], v[1], v[2], 0, -v[0], -v[1], v[0], 0;
  return c;
}

void summarise(const CameraModel& model, UncertaintyGrid& g) {
  std::vector<double> finite;
  for (double x : g.worst_px)
    if (std::isfinite(x)) finite.push_back(x);
  if (finite.empty()) {
    g.centre_px = g.median_px = g.corner_px = kNaN;
    return;
  }
  std::nth_element(finite.begin(), finite.begin() + finite.size() / 2, finite.end());
  g.median_px = finite[finite.size() / 2];
  auto nearest = [&](double x, double y) {
    size_t best = 0;
    double bd = std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < g.pixel.size(); ++i) {
      const double d = std::hypot(g.pixel[i][0] - x, g.pixel[i][1] - y);
      if (d < bd) {
        bd = d;
        best = i;
      }
    }
    return best;
  };
  g.centre_px = g.worst_px[nearest((model.width - 1) / 2.0, (model.height - 1) / 2.0)];
  g.corner_px = kNaN;
  for (const auto& c : {std::array<double, 2>{0, 0}, std::array<double, 2>{double(model.width - 1), 0},
                        std::array<double, 2>{0, double(model.height - 1)},
                        std::array<double, 2>{double(model.width - 1), double(model.height - 1)}}) {
    const double v = g.worst_px[nearest(c[0], c[1])];
    if (std::isfinite(v) && !(v <= g.corner_px)) g.corner_px = v;
  }
}

void set_from_covariance(UncertaintyGrid& g, size_t i, const Eigen::Matrix2d& C) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(C);
  g.worst_px[i] = std::sqrt(std::max(0.0, es.eigenvalues()[1]));
  g.rms_px[i] = std::sqrt(std::max(0.0, C.trace()));
}

UncertaintyGrid empty_grid(const std::vector<std::array<double, 2>>& pixels, int nx, int ny) {
  UncertaintyGrid g;
  g.nx = nx;
  g.ny = ny;
  g.pixel = pixels;
  g.worst_px.assign(pixels.size(), kNaN);
  g.rms_px.assign(pixels.size(), kNaN);
  g.centre_px = g.median_px = g.corner_px = kNaN;  // until summarised
  return g;
}

}  // namespace

LinearCovariance linearised_covariance(const CameraModel& model, const BoardSpec& board,
                                       const std::vector<SolvedView>& views, const BoardWarp* warp) {
  LinearCovariance out;
  if (LensModel::parse(model.lensmodel).is_splined()) {
    out.error = "splined models are not supported (their regularisation is not modelled)";
    return out;
  }
  const int ncorners = board.cols * board.rows;
  const int n = int(model.intrinsics.size());
  const int W = warp ? 2 : 0;  // the warp's parameters, last
  const int P = n + 6 * int(views.size()) + W;
  out.intrinsics = n;
  out.params = P - W;
  Eigen::MatrixXd JtJ = Eigen::MatrixXd::Zero(P, P);
  double ssr = 0;
  int used = 0;
  CameraModel t = model;
  for (size_t v = 0; v < views.size(); ++v) {
    const SolvedView& sv = views[v];
    if (int(sv.px.size()) != ncorners || sv.inlier.size() != sv.px.size())
      throw InputError("linearised_covariance: view " + std::to_string(v) + " has " + std::to_string(sv.px.size()) +
                       " corners, the board has " + std::to_string(ncorners));
    std::array<double, 6> pose = sv.pose;
    auto corner_in_camera = [&](const std::array<double, 6>& p, int k) {
      const Eigen::Vector3d X((k % board.cols) * board.square_mm, (k / board.cols) * board.square_mm,
                              warp ? board_warp_z(board, k, *warp) : 0.0);
      return Eigen::Vector3d(rotation_of(p.data()) * X + Eigen::Vector3d(p[3], p[4], p[5]));
    };
    for (int k = 0; k < ncorners; ++k) {
      if (!sv.inlier[k]) continue;
      const Eigen::Vector3d C = corner_in_camera(pose, k);
      const auto q = proj(model, C);
      if (!q) continue;
      Eigen::MatrixXd J(2, n + 6 + W);
      Eigen::MatrixXd G;
      if (!intrinsics_jacobian(model, C, G)) continue;
      J.leftCols(n) = G;
      bool ok = true;
      for (int j = 0; j < 6 && ok; ++j) {
        const double h = j < 3 ? 1e-6 : step_for(pose[j]);
        std::array<double, 6> a = pose, b = pose;
        a[j] += h;
        b[j] -= h;
        const auto qa = proj(model, corner_in_camera(a, k)), qb = proj(model, corner_in_camera(b, k));
        if (!qa || !qb) ok = false;
        else J.col(n + j) = (*qa - *qb) / (2 * h);
      }
      if (!ok) continue;
      if (warp) {
        // The corner moves along the board's z axis (the pose's third rotation column) by
        // the warp's parabola factors: chain rule through the projection's point Jacobian.
        Eigen::Matrix<double, 2, 3> Jp;
        if (!point_jacobian(model, C, Jp)) continue;
        const Eigen::Vector2d dq_dz = Jp * rotation_of(pose.data()).col(2);
        J.col(n + 6) = dq_dz * board_warp_z(board, k, {1, 0});
        J.col(n + 7) = dq_dz * board_warp_z(board, k, {0, 1});
      }
      const Eigen::Vector2d r(sv.px[k][0] - (*q)[0], sv.px[k][1] - (*q)[1]);
      ssr += r.squaredNorm();
      ++used;
      // Blocks: intrinsics x intrinsics, intrinsics x this pose, this pose x this pose.
      const int o = n + 6 * int(v);
      const Eigen::MatrixXd JtJl = J.transpose() * J;
      JtJ.topLeftCorner(n, n) += JtJl.topLeftCorner(n, n);
      JtJ.block(0, o, n, 6) += JtJl.block(0, n, n, 6);
      JtJ.block(o, 0, 6, n) += JtJl.block(n, 0, 6, n);
      JtJ.block(o, o, 6, 6) += JtJl.block(n, n, 6, 6);
      if (W) {  // warp x intrinsics, warp x this pose, warp x warp
        const int w = P - W;
        JtJ.block(w, 0, W, n) += JtJl.block(n + 6, 0, W, n);
        JtJ.block(0, w, n, W) += JtJl.block(0, n + 6, n, W);
        JtJ.block(w, o, W, 6) += JtJl.block(n + 6, n, W, 6);
        JtJ.block(o, w, 6, W) += JtJl.block(n, n + 6, 6, W);
        JtJ.block(w, w, W, W) += JtJl.block(n + 6, n + 6, W, W);
      }
    }
  }
  const int dof = 2 * used - P;
  if (dof <= 0) {
    out.error = "fewer observations than parameters";
    return out;
  }
  out.sigma_px = std::sqrt(ssr / dof);
  // Scale the columns to unit diagonal before inverting: fx (hundreds) and k4 (1e-4) differ
  // by many orders of magnitude.
  Eigen::VectorXd d = JtJ.diagonal().cwiseSqrt();
  for (int i = 0; i < P; ++i)
    if (!(d[i] > 0)) {
      out.error = "a parameter is not observed (J^T J singular)";
      return out;
    }
  const Eigen::MatrixXd S = d.cwiseInverse().asDiagonal() * JtJ * d.cwiseInverse().asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(S);
  if (es.info() != Eigen::Success || !(es.eigenvalues()[0] > 1e-14 * es.eigenvalues()[P - 1])) {
    out.error = "J^T J is singular (the views do not constrain every parameter)";
    return out;
  }
  const Eigen::MatrixXd Sinv =
      es.eigenvectors() * es.eigenvalues().cwiseInverse().asDiagonal() * es.eigenvectors().transpose();
  const Eigen::MatrixXd cov =
      out.sigma_px * out.sigma_px * (d.cwiseInverse().asDiagonal() * Sinv * d.cwiseInverse().asDiagonal());
  const Eigen::MatrixXd marginal = cov.topLeftCorner(P - W, P - W);
  out.covariance.assign(marginal.data(), marginal.data() + size_t(P - W) * (P - W));  // symmetric: layout does not matter
  if (W) out.warp_covariance = {cov(P - 2, P - 2), cov(P - 2, P - 1), cov(P - 1, P - 2), cov(P - 1, P - 1)};
  out.ok = true;
  return out;
}

std::vector<std::array<double, 2>> grid_pixels(const CameraModel& model, int nx, int ny) {
  std::vector<std::array<double, 2>> out;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i)
      out.push_back({(i + 0.5) * model.width / nx - 0.5, (j + 0.5) * model.height / ny - 0.5});
  return out;
}

std::vector<std::array<double, 2>> mask_pixels(const std::vector<uint8_t>& mask, int width, int height, int step_px) {
  std::vector<std::array<double, 2>> out;
  const int step = std::max(1, step_px);
  for (int y = step / 2; y < height; y += step)
    for (int x = step / 2; x < width; x += step)
      if (mask.empty() || mask[size_t(y) * width + x]) out.push_back({double(x), double(y)});
  return out;
}

UncertaintyGrid linear_uncertainty_mean_frames(const LinearCovariance& cov, const CameraModel& model,
                                               const std::vector<SolvedView>& views,
                                               const std::vector<std::array<double, 2>>& pixels, int nx, int ny) {
  UncertaintyGrid g = empty_grid(pixels, nx, ny);
  if (!cov.ok) return g;
  const int n = cov.intrinsics, P = cov.params, V = int(views.size());
  if (P != n + 6 * V) throw InputError("linear_uncertainty_mean_frames: covariance and views disagree");
  const Eigen::Map<const Eigen::MatrixXd> C(cov.covariance.data(), P, P);
  std::vector<Eigen::Matrix3d> R(V);
  for (int i = 0; i < V; ++i) R[i] = rotation_of(views[i].pose.data());
  for (size_t p = 0; p < pixels.size(); ++p) {
    const auto ray = unproject(model, {pixels[p][0], pixels[p][1]});
    if (!ray) continue;
    const Eigen::Vector3d v(ray->x, ray->y, ray->z);
    Eigen::MatrixXd A = Eigen::MatrixXd::Zero(2, P);
    Eigen::MatrixXd G;
    Eigen::Matrix<double, 2, 3> Jp;
    if (!intrinsics_jacobian(model, v, G) || !point_jacobian(model, v, Jp)) continue;
    A.leftCols(n) = G;
    // The ray at infinity, carried into board frame i (R_i^T v) and back through the
    // perturbed pose R(r_i + d): mean over the views, so d/dr_i is 1/V of one view's.
    for (int i = 0; i < V; ++i) {
      const Eigen::Vector3d f = R[i].transpose() * v;
      Eigen::Matrix3d D;
      for (int k = 0; k < 3; ++k) {
        std::array<double, 3> a{views[i].pose[0], views[i].pose[1], views[i].pose[2]}, b = a;
        a[k] += 1e-6;
        b[k] -= 1e-6;
        D.col(k) = (rotation_of(a.data()) * f - rotation_of(b.data()) * f) / 2e-6;
      }
      A.block(0, n + 6 * i, 2, 3) = Jp * D / V;
    }
    set_from_covariance(g, p, A * C * A.transpose());
  }
  summarise(model, g);
  return g;
}

UncertaintyGrid linear_uncertainty_rotation_fitted(const LinearCovariance& cov, const CameraModel& model,
                                                   const std::vector<uint8_t>& fit_mask, int fit_step_px,
                                                   const std::vector<std::array<double, 2>>& pixels, int nx, int ny) {
  UncertaintyGrid g = empty_grid(pixels, nx, ny);
  if (!cov.ok) return g;
  const int n = cov.intrinsics, P = cov.params;
  const Eigen::Map<const Eigen::MatrixXd> Cfull(cov.covariance.data(), P, P);
  const Eigen::MatrixXd C = Cfull.topLeftCorner(n, n);  // marginal over the poses
  // dq/d intrinsics (G) and dq/d camera rotation (H = Jp * d(R(w) v)/dw = -Jp [v]x) at a pixel.
  auto jacobians = [&](const std::array<double, 2>& q, Eigen::MatrixXd& G, Eigen::Matrix<double, 2, 3>& H) {
    const auto ray = unproject(model, {q[0], q[1]});
    if (!ray) return false;
    const Eigen::Vector3d v(ray->x, ray->y, ray->z);
    Eigen::Matrix<double, 2, 3> Jp;
    if (!intrinsics_jacobian(model, v, G) || !point_jacobian(model, v, Jp)) return false;
    H = -Jp * cross_matrix(v);
    return true;
  };
  // The rotation that best absorbs an intrinsics perturbation over the covered area (in
  // pixels, least squares): w = -M dI.
  Eigen::Matrix3d HtH = Eigen::Matrix3d::Zero();
  Eigen::MatrixXd HtG = Eigen::MatrixXd::Zero(3, n);
  for (const auto& q : mask_pixels(fit_mask, model.width, model.height, fit_step_px)) {
    Eigen::MatrixXd G;
    Eigen::Matrix<double, 2, 3> H;
    if (!jacobians(q, G, H)) continue;
    HtH += H.transpose() * H;
    HtG += H.transpose() * G;
  }
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(3, n);
  if (HtH.determinant() > 0) M = HtH.ldlt().solve(HtG);
  for (size_t p = 0; p < pixels.size(); ++p) {
    Eigen::MatrixXd G;
    Eigen::Matrix<double, 2, 3> H;
    if (!jacobians(pixels[p], G, H)) continue;
    const Eigen::MatrixXd Gf = G - H * M;
    set_from_covariance(g, p, Gf * C * Gf.transpose());
  }
  summarise(model, g);
  return g;
}

namespace {

// b's rays at `pixels` (nullopt where b has none).
std::vector<std::optional<Vec3>> rays_of(const CameraModel& b, const std::vector<std::array<double, 2>>& pixels) {
  std::vector<std::optional<Vec3>> out;
  out.reserve(pixels.size());
  for (const auto& q : pixels) out.push_back(unproject(b, {q[0], q[1]}));
  return out;
}

// The rotation that best aligns a's rays with b's (identity with fewer than 3 pairs).
Eigen::Matrix3d aligning_rotation(const std::vector<std::optional<Vec3>>& a_rays,
                                  const std::vector<std::optional<Vec3>>& b_rays) {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  int count = 0;
  for (size_t i = 0; i < a_rays.size(); ++i) {
    const auto& da = a_rays[i];
    const auto& db = b_rays[i];
    if (!da || !db) continue;
    H += Eigen::Vector3d(da->x, da->y, da->z) * Eigen::Vector3d(db->x, db->y, db->z).transpose();
    ++count;
  }
  if (count >= 3) {
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
    const Eigen::Matrix3d U = svd.matrixU(), V = svd.matrixV();
    Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
    S(2, 2) = (V * U.transpose()).determinant() < 0 ? -1 : 1;
    R = V * S * U.transpose();
  }
  return R;
}

// a's rays (rotated by R) projected with b, minus the pixels; NaN where either has none.
std::vector<std::array<double, 2>> rotated_differences(const std::vector<std::optional<Vec3>>& a_rays,
                                                       const Eigen::Matrix3d& R, const CameraModel& b,
                                                       const std::vector<std::array<double, 2>>& pixels) {
  std::vector<std::array<double, 2>> out(pixels.size(), {kNaN, kNaN});
  for (size_t i = 0; i < pixels.size(); ++i) {
    const auto& da = a_rays[i];
    if (!da) continue;
    const Eigen::Vector3d r = R * Eigen::Vector3d(da->x, da->y, da->z);
    const auto q = project(b, {r[0], r[1], r[2]});
    if (!q) continue;
    out[i] = {q->x - pixels[i][0], q->y - pixels[i][1]};
  }
  return out;
}

// The per-pixel covariance of the leave-one-out differences d[model][pixel], scaled as a
// jackknife's, into g.
void jackknife_spread(const std::vector<std::vector<std::array<double, 2>>>& d, UncertaintyGrid& g) {
  const size_t n = d.size();
  for (size_t p = 0; p < g.rms_px.size(); ++p) {
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    bool ok = true;
    for (size_t i = 0; i < n && ok; ++i) {
      ok = std::isfinite(d[i][p][0]) && std::isfinite(d[i][p][1]);
      if (ok) mean += Eigen::Vector2d(d[i][p][0], d[i][p][1]);
    }
    if (!ok) continue;
    mean /= double(n);
    Eigen::Matrix2d C = Eigen::Matrix2d::Zero();
    for (size_t i = 0; i < n; ++i) {
      const Eigen::Vector2d e = Eigen::Vector2d(d[i][p][0], d[i][p][1]) - mean;
      C += e * e.transpose();
    }
    set_from_covariance(g, p, C * (double(n - 1) / double(n)));
  }
}

}  // namespace

std::vector<std::array<double, 2>> projection_difference_vectors(const CameraModel& a, const CameraModel& b,
                                                                 const std::vector<std::array<double, 2>>& fit_pixels,
                                                                 const std::vector<std::array<double, 2>>& pixels,
                                                                 bool fit_rotation) {
  const Eigen::Matrix3d R = fit_rotation ? aligning_rotation(rays_of(a, fit_pixels), rays_of(b, fit_pixels))
                                         : Eigen::Matrix3d::Identity();
  return rotated_differences(rays_of(a, pixels), R, b, pixels);
}

UncertaintyGrid jackknife_uncertainty(const CameraModel& full, const std::vector<CameraModel>& leave_one_out,
                                      const std::vector<std::array<double, 2>>& fit_pixels,
                                      const std::vector<std::array<double, 2>>& pixels, int nx, int ny,
                                      UncertaintyGrid* at_fit, bool parallel) {
  UncertaintyGrid g = empty_grid(pixels, nx, ny);
  if (at_fit) *at_fit = empty_grid(fit_pixels, int(fit_pixels.size()), 1);
  const size_t n = leave_one_out.size();
  if (n < 2) return g;
  // Each model's rays at fit_pixels serve its rotation and, with at_fit, its differences there.
  const auto full_rays = rays_of(full, fit_pixels);
  std::vector<std::vector<std::array<double, 2>>> d(n), d_fit(at_fit ? n : 0);
  run_jobs(n, [&](size_t i) {
    const CameraModel& m = leave_one_out[i];
    const auto fit_rays = rays_of(m, fit_pixels);
    const Eigen::Matrix3d R = aligning_rotation(fit_rays, full_rays);
    d[i] = rotated_differences(rays_of(m, pixels), R, full, pixels);
    if (at_fit) d_fit[i] = rotated_differences(fit_rays, R, full, fit_pixels);
  }, parallel ? 0 : 1);
  jackknife_spread(d, g);
  summarise(full, g);
  if (at_fit) {
    jackknife_spread(d_fit, *at_fit);
    summarise(full, *at_fit);
  }
  return g;
}

double rms_over(const UncertaintyGrid& g) {
  double s = 0;
  int k = 0;
  for (double x : g.rms_px)
    if (std::isfinite(x)) {
      s += x * x;
      ++k;
    }
  return k ? std::sqrt(s / k) : kNaN;
}

}  // namespace lp
