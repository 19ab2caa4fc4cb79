#include "calib/calibration_solve.h"

#include <cmath>

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include "calib/mrcal_solve.h"

namespace lp {
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

// Joint solve of intrinsics (Projection's), poses and, with SolveOptions::board_warp, the
// board warp from `seed`; the seed when it fails or does not improve.
template <class Projection>
ModelFit refine_joint(const CalibrationProblem& pr, const ViewSubset& views, const ModelFit& seed) {
  ModelFit f = seed;
  if (!pr.solve.board_warp) f.warp = {0, 0};
  ceres::Problem problem;
  for (size_t i = 0; i < views.size(); ++i)
    for (size_t k = 0; k < views[i]->px.size(); ++k) {
      if (!views[i]->inlier[k]) continue;
      const auto X = board_point(pr.board, int(k));
      using Cost = CornerCost<Projection>;
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<Cost, 2, Projection::kParams, 6, 2>(new Cost{
                                   X[0], X[1], board_warp_z(pr.board, int(k), {1, 0}),
                                   board_warp_z(pr.board, int(k), {0, 1}), views[i]->px[k][0], views[i]->px[k][1]}),
                               nullptr, f.model.intrinsics.data(), f.poses[i].data(), f.warp.data());
    }
  if (!pr.solve.board_warp) problem.SetParameterBlockConstant(f.warp.data());
  f.warp_fitted = pr.solve.board_warp;
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
  bool finite = summary.IsSolutionUsable();
  for (double x : f.model.intrinsics) finite = finite && std::isfinite(x);
  finite = finite && std::isfinite(f.warp[0]) && std::isfinite(f.warp[1]);
  if (!finite || summary.final_cost > summary.initial_cost) return seed;
  if (f.solver.find("Ceres") == std::string::npos) f.solver += " + Ceres";
  return f;
}

// mrcal's polish of a cv::calibrateCamera fit, from its rounded seed; OpenCV's solution
// when mrcal fails or does not improve it.
ModelFit polish(const CalibrationProblem& pr, const ViewSubset& views, const ModelFit& raw) {
  if (!raw.ok || !pr.solve.use_mrcal) return raw;
  const ModelFit seed = rounded_seed(raw);
  ModelFit f = solve_mrcal(pr, views, raw.model.lensmodel, seed.model.intrinsics, seed.poses, false);
  if (!f.ok || fit_rms(pr, f, views) > fit_rms(pr, raw, views)) return raw;
  f.solver = raw.solver + " + mrcal";
  return f;
}

}  // namespace

ModelFit refine_kannala_brandt(const CalibrationProblem& pr, const ViewSubset& views, const ModelFit& seed) {
  return refine_joint<KannalaBrandtProjection>(pr, views, seed);
}

ModelFit refine_mei(const CalibrationProblem& pr, const ViewSubset& views, const ModelFit& seed) {
  return refine_joint<MeiProjection>(pr, views, seed);
}

ModelFit solve_mrcal(const CalibrationProblem& pr, const ViewSubset& views, const std::string& lensmodel,
                     std::vector<double> intrinsics, const std::vector<BoardPose>& poses, bool regularization,
                     const BoardWarp& warp) {
  ModelFit f;
  MrcalProblem mp;
  mp.optimize_warp = pr.solve.board_warp;
  mp.warp_seed = pr.solve.board_warp ? warp : BoardWarp{0, 0};
  mp.lensmodel = lensmodel;
  mp.intrinsics_seed = std::move(intrinsics);
  mp.poses_seed = poses;
  mp.width = pr.width;
  mp.height = pr.height;
  mp.cols = pr.board.cols;
  mp.rows = pr.board.rows;
  mp.spacing = pr.board.square_mm;
  mp.regularization = regularization;
  for (const BoardView* v : views) {
    mp.observations.emplace_back();
    for (size_t k = 0; k < v->px.size(); ++k)
      mp.observations.back().push_back({v->px[k][0], v->px[k][1], v->inlier[k] ? 1.0 : -1.0});
  }
  const MrcalSolution s = mrcal_solve(mp);
  if (!s.ok) {
    f.error = s.error;
    return f;
  }
  f.model = make_model(pr, lensmodel, s.intrinsics);
  f.poses = s.poses;
  f.warp = s.warp;
  f.warp_fitted = mp.optimize_warp;
  f.params = int(s.intrinsics.size());
  f.solver = "mrcal";
  f.ok = true;
  return f;
}

const ModelFit& CandidateSolver::get(LensType type) {
  {
    std::unique_lock lock(mutex_);
    solved_.wait(lock, [&] { return !solving_.count(type); });
    auto it = cache_.find(type);
    if (it != cache_.end()) return it->second;
    solving_.insert(type);
  }
  // Solved outside the lock: other candidates proceed meanwhile. (Seeds depend on other
  // candidates without cycles, so a thread never waits for a fit it is solving itself.)
  ModelFit f;
  try {
    f = solve(type);
  } catch (...) {
    std::lock_guard lock(mutex_);
    solving_.erase(type);
    solved_.notify_all();
    throw;
  }
  return adopt(type, std::move(f));
}

const ModelFit& CandidateSolver::adopt(LensType type, ModelFit f) {
  if (f.ok && !std::isfinite(fit_rms(problem_, f, views_))) {
    f.ok = false;
    f.error = "the fit cannot image some corners";
  }
  std::lock_guard lock(mutex_);
  const ModelFit& kept = cache_.try_emplace(type, std::move(f)).first->second;
  solving_.erase(type);
  solved_.notify_all();
  return kept;
}

namespace {

// The models whose OpenCV seed is cubic in the views (SeedOptions::sample_views).
bool seeds_on_a_sample(LensType type) {
  return type == LensType::Pinhole || type == LensType::OpenCV5 || type == LensType::OpenCV8 ||
         type == LensType::OmnidirMei;
}

}  // namespace

ModelFit CandidateSolver::solve(LensType type) {
  const bool mei = type == LensType::OmnidirMei;
  if (seed_.sample_views >= 4 && views_.size() >= 2 * size_t(seed_.sample_views) && seeds_on_a_sample(type) &&
      (mei || problem_.solve.use_mrcal)) {
    // Solved on the sample, every view posed under that fit, then refined on all of them.
    const ViewSubset sample = evenly_spaced(views_, size_t(seed_.sample_views));
    CandidateSolver on_sample(problem_, sample, seed_);
    const ModelFit& s = on_sample.get(type);
    if (s.ok) {
      ModelFit seed = s;
      seed.poses.clear();
      bool posed = true;
      for (size_t i = 0, j = 0; i < views_.size() && posed; ++i) {
        if (j < sample.size() && sample[j] == views_[i]) {
          seed.poses.push_back(s.poses[j++]);
        } else if (const auto p = solve_pose(problem_, s.model, s.warp, *views_[i])) {
          seed.poses.push_back(*p);
        } else {
          posed = false;
        }
      }
      if (posed) {
        ModelFit f = mei ? refine_mei(problem_, views_, seed)
                         : solve_mrcal(problem_, views_, s.model.lensmodel, s.model.intrinsics, seed.poses, false, s.warp);
        if (f.ok) {
          f.solver = s.solver + " on " + std::to_string(sample.size()) + " views, refined on all";
          return f;
        }
      }
    }
    // A view the sample's fit cannot pose, or a refinement that fails: the whole solve.
  }
  const SeedReport seed =
      seed_candidate(problem_, views_, type, [this](LensType t) -> const ModelFit& { return get(t); }, seed_);
  if (!seed.fit.ok) return seed.fit;
  switch (type) {
    case LensType::KannalaBrandt:
      return refine_kannala_brandt(problem_, views_, seed.fit);
    case LensType::OmnidirMei:
      return refine_mei(problem_, views_, seed.fit);
    case LensType::Stereographic:
    case LensType::SplinedStereographic: {
      ModelFit f = solve_mrcal(problem_, views_, seed.fit.model.lensmodel, seed.fit.model.intrinsics, seed.fit.poses,
                               type == LensType::SplinedStereographic, seed.fit.warp);
      if (f.ok) f.solver = seed.fit.solver + " + mrcal";
      return f;
    }
    default:
      return polish(problem_, views_, seed.fit);
  }
}

ModelFit warm_refit(const CalibrationProblem& pr, const ViewSubset& views, LensType type, const ModelFit& from,
                    const std::vector<BoardPose>& poses) {
  ModelFit seed = from;
  seed.poses = poses;
  if (type == LensType::KannalaBrandt) return refine_kannala_brandt(pr, views, seed);
  if (type == LensType::OmnidirMei) return refine_mei(pr, views, seed);
  if (pr.solve.use_mrcal) {
    ModelFit f = solve_mrcal(pr, views, from.model.lensmodel, from.model.intrinsics, poses,
                             LensModel::parse(from.model.lensmodel).is_splined(), from.warp);
    if (f.ok) return f;
  }
  CandidateSolver cold(pr, views);
  return cold.get(type);
}

}  // namespace lp
