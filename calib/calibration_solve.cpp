#include "calib/calibration_solve.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include <opencv2/core.hpp>

#include "calib/ceres_plugin.h"
#include "calib/mrcal_solve.h"

namespace lp {
namespace {

// Joint solve of intrinsics (the projection's), poses and, with SolveOptions::board_warp,
// the board warp from `seed` (Ceres, in the plugin of calib/ceres_plugin.h); the seed when it
// fails or does not improve.
ModelFit refine_joint(const CalibrationProblem& pr, const ViewSubset& views, const ModelFit& seed,
                      detail::CeresProjection projection, int stall_after = 0) {
  ModelFit f = seed;
  if (!pr.solve.board_warp) f.warp = {0, 0};
  std::vector<detail::CeresCorner> corners;
  for (size_t i = 0; i < views.size(); ++i)
    for (size_t k = 0; k < views[i]->px.size(); ++k) {
      if (!views[i]->inlier[k]) continue;
      const auto X = board_point(pr.board, int(k));
      corners.push_back({X[0], X[1], board_warp_z(pr.board, int(k), {1, 0}), board_warp_z(pr.board, int(k), {0, 1}),
                         views[i]->px[k][0], views[i]->px[k][1], i});
    }
  std::vector<double*> poses;
  for (BoardPose& pose : f.poses) poses.push_back(pose.data());
  if (f.model.intrinsics.size() != size_t(detail::kCeresProjectionParams[int(projection)]) || poses.size() < views.size())
    return seed;  // not a fit of this projection: nothing to refine
  detail::CeresJointSolve problem;
  problem.projection = projection;
  problem.corners = corners.data();
  problem.corner_count = corners.size();
  problem.intrinsics = f.model.intrinsics.data();
  problem.poses = poses.data();
  problem.warp = f.warp.data();
  problem.fit_warp = pr.solve.board_warp;
  problem.stall_after = stall_after;
  f.warp_fitted = pr.solve.board_warp;
  // Ceres and its 17 libraries are loaded by the first solve (calib/ceres_plugin.h).
  const detail::CeresSolveSummary summary = detail::ceres_plugin().solve_joint(problem);
  bool finite = summary.usable;
  for (double x : f.model.intrinsics) finite = finite && std::isfinite(x);
  finite = finite && std::isfinite(f.warp[0]) && std::isfinite(f.warp[1]);
  if (!finite || summary.final_cost > summary.initial_cost) return seed;
  if (f.solver.find("Ceres") == std::string::npos) f.solver += " + Ceres";
  f.iterations = summary.iterations;
  return f;
}

// The widest angle off the axis at which `fit`'s poses put a used corner of `views`, deg.
double posed_field_deg(const CalibrationProblem& pr, const ViewSubset& views, const ModelFit& fit) {
  const std::vector<double> angles = posed_corner_angles(pr, views, fit);
  return angles.empty() ? 0.0 : *std::max_element(angles.begin(), angles.end()) * 180 / M_PI;
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
  return refine_joint(pr, views, seed, detail::CeresProjection::KannalaBrandt, pr.solve.kannala_brandt_stall_after);
}

ModelFit refine_mei(const CalibrationProblem& pr, const ViewSubset& views, const ModelFit& seed) {
  // On a narrow field, in its radial profile's coordinates (SolveOptions::mei_profile_field_deg).
  // Their focal length is f / (1 + xi): a seed with xi near -1 (its projection centre near
  // the sphere's far pole) stays in Mei's own.
  const double limit = pr.solve.mei_profile_field_deg;
  const bool narrow = limit > 0 && seed.model.intrinsics.size() == 9 && seed.model.intrinsics[4] > -0.5 &&
                      posed_field_deg(pr, views, seed) <= limit;
  return refine_joint(pr, views, seed, narrow ? detail::CeresProjection::MeiProfile : detail::CeresProjection::Mei);
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

const ModelFit* CandidateSolver::solved(LensType type) {
  std::lock_guard lock(mutex_);
  const auto it = cache_.find(type);
  return it == cache_.end() ? nullptr : &it->second;
}

void CandidateSolver::replace(LensType type, ModelFit fit) {
  std::lock_guard lock(mutex_);
  cache_[type] = std::move(fit);
}

void CandidateSolver::reuse_sample_fits(CandidateSolver& sample_solver) {
  std::lock_guard lock(sample_solver.mutex_);
  sample_views_ = sample_solver.views_;
  sample_fits_ = sample_solver.cache_;
}

namespace {

// The models whose OpenCV seed grows fast with the views (SeedOptions::sample_views): cubic
// for cv::calibrateCamera and cv::omnidir; cv::fisheye is linear but re-solves every view's
// homography in each of its iterations (~0.5 ms a view and iteration: 1.1 s on 64 views).
// Mei's seed is the unit-xi search since stop 46 (linear in the views; cv::omnidir only as
// its fallback), and Mei still solves the sample first: the gain was measured with
// cv::omnidir and not since.
bool seeds_on_a_sample(LensType type) {
  return type == LensType::Pinhole || type == LensType::OpenCV5 || type == LensType::OpenCV8 ||
         type == LensType::OmnidirMei || type == LensType::KannalaBrandt;
}

}  // namespace

namespace {

// A Mei fit whose xi walked off along its valley: on a narrow lens xi is barely observable,
// and from the unit-xi seed the refinement can cross s = 1 + xi = 0 (where the radial profile's
// coordinates are singular) and run on to xi = -4e7 with a focal length of -2e10 px: a model
// that images no pixel (the stereo set's halves, --model LENSMODEL_OMNIDIR_MEI).
bool mei_walked_off(const ModelFit& f) {
  if (!f.ok || f.model.intrinsics.size() != 9) return false;
  const double fx = f.model.intrinsics[0], xi = f.model.intrinsics[4];
  return !(xi > -1 + 1e-6 && xi < 1e3 && fx > 0 && std::isfinite(fx));
}

}  // namespace

// A joint fit can keep a view in the wrong one of a planar board's two poses (a small,
// distant board seen nearly face on): the solver does not cross between them, and the
// intrinsics bend to fit the flipped view (an audit's synthetic 1920x1080 plumb_bob lens:
// one such view left the fit at 0.124 px RMS against 0.034 px held out, 4.7 px from the
// truth). Each view that fits more than kStuckFactor times worse than the median view is
// posed again under the fit's intrinsics (solve_pose tries both of IPPE's poses); where
// that fits the view much better, every view is refitted warm from the new poses, and
// kept when the whole fit improves. Not where the typical view misses by more than
// kHopelessPx: a model that cannot fit the lens at all (Kannala-Brandt on MiniOmni's mirror,
// 1e6 px) has no flipped view to find. Below it one view can matter: Kannala-Brandt on the
// VMRImage mirror, typical view 2.2 px, fits every view at 0.34 px once one is posed again.
ModelFit repose_stuck_views(const CalibrationProblem& pr, const ViewSubset& views, LensType type, const ModelFit& f) {
  constexpr double kStuckFactor = 3, kBetter = 0.5, kHopelessPx = 20;
  if (!f.ok || f.poses.size() != views.size() || views.size() < 3) return f;
  std::vector<double> rms(views.size());
  for (size_t i = 0; i < views.size(); ++i) {
    const size_t n = size_t(std::count(views[i]->inlier.begin(), views[i]->inlier.end(), 1));
    rms[i] = n ? std::sqrt(view_squared_error(pr, f.model, f.warp, *views[i], f.poses[i]) / double(n)) : 0.0;
  }
  const double typical = median_of(rms);
  if (!(typical <= kHopelessPx)) return f;
  std::vector<BoardPose> poses = f.poses;
  int moved = 0;
  for (size_t i = 0; i < views.size(); ++i) {
    if (!(rms[i] > kStuckFactor * typical)) continue;
    const auto p = solve_pose(pr, f.model, f.warp, *views[i]);
    if (p && view_squared_error(pr, f.model, f.warp, *views[i], *p) <
                 kBetter * view_squared_error(pr, f.model, f.warp, *views[i], f.poses[i])) {
      poses[i] = *p;
      ++moved;
    }
  }
  if (moved == 0) return f;
  ModelFit g = warm_refit(pr, views, type, f, poses);
  if (!g.ok || !(fit_rms(pr, g, views) < fit_rms(pr, f, views))) return f;
  g.solver = f.solver + ", " + std::to_string(moved) + (moved == 1 ? " view" : " views") + " posed again";
  return g;
}

ModelFit CandidateSolver::solve(LensType type) {
  ModelFit f = repose_stuck_views(problem_, views_, type, solve_seeded(type, problem_));
  if (type != LensType::OmnidirMei || problem_.solve.mei_from_kannala_brandt || !mei_walked_off(f)) return f;
  // Seeded from the Kannala-Brandt fit instead, as the automatic choice seeds Mei on such a
  // lens (a forced Mei keeps the unit-xi seed, which mirrors need: see reject_outliers).
  CalibrationProblem from_kb = problem_;
  from_kb.solve.mei_from_kannala_brandt = true;
  ModelFit g = solve_seeded(type, from_kb);
  if (g.ok && !mei_walked_off(g)) {
    g.solver += " (the unit-xi seed's xi walked off)";
    return g;
  }
  char buf[200];
  std::snprintf(buf, sizeof buf, "Mei's xi walked off to %.3g (focal length %.3g px): too narrow a lens to pin it",
                f.model.intrinsics[4], f.model.intrinsics[0]);
  f.ok = false;
  f.error = buf;
  return f;
}

ModelFit CandidateSolver::solve_seeded(LensType type, const CalibrationProblem& pr) {
  const bool mei = type == LensType::OmnidirMei, kb = type == LensType::KannalaBrandt;
  if (seed_.sample_views >= 4 && views_.size() >= 2 * size_t(seed_.sample_views) && seeds_on_a_sample(type) &&
      (mei || kb || pr.solve.use_mrcal)) {
    // Solved on the sample, every view posed under that fit, then refined on all of them.
    const ViewSubset sample = evenly_spaced(views_, size_t(seed_.sample_views));
    CandidateSolver on_sample(pr, sample, seed_);
    if (const auto it = sample_fits_.find(type); it != sample_fits_.end() && sample == sample_views_)
      on_sample.adopt(type, it->second);
    const ModelFit& s = on_sample.get(type);
    if (s.ok) {
      ModelFit seed = s;
      seed.poses.clear();
      bool posed = true;
      for (size_t i = 0, j = 0; i < views_.size() && posed; ++i) {
        if (j < sample.size() && sample[j] == views_[i]) {
          seed.poses.push_back(s.poses[j++]);
        } else if (const auto p = solve_pose(pr, s.model, s.warp, *views_[i])) {
          seed.poses.push_back(*p);
        } else {
          posed = false;
        }
      }
      if (posed) {
        ModelFit f = mei  ? refine_mei(pr, views_, seed)
                     : kb ? refine_kannala_brandt(pr, views_, seed)
                          : solve_mrcal(pr, views_, s.model.lensmodel, s.model.intrinsics, seed.poses, false,
                                        s.warp);
        if (f.ok) {
          f.solver = s.solver + " on " + std::to_string(sample.size()) + " views, refined on all";
          return f;
        }
      }
    }
    // A view the sample's fit cannot pose, or a refinement that fails: the whole solve.
  }
  const SeedReport seed =
      seed_candidate(pr, views_, type, [this](LensType t) -> const ModelFit& { return get(t); }, seed_);
  ModelFit f = refine_seed(pr, views_, type, seed.fit);
  if (type == LensType::OpenCV8) {
    f = rational_from_plumb_bob(pr, views_, std::move(f), get(LensType::OpenCV5));
    // Kannala-Brandt is solved for it only where the rational fit sees a wide field itself.
    if (!f.ok || corner_field_deg(f.model, views_) > kRationalFromWideProfileFieldDeg - 10)
      f = rational_from_wide_profile(pr, views_, std::move(f), get(LensType::KannalaBrandt));
  }
  return f;
}

ModelFit rational_from_plumb_bob(const CalibrationProblem& pr, const ViewSubset& views, ModelFit rational,
                                 const ModelFit& plumb_bob) {
  if (!pr.solve.use_mrcal || !plumb_bob.ok || plumb_bob.model.intrinsics.size() != 9) return rational;
  // The rational model holds plumb_bob's projection: a fit at least as good as plumb_bob's
  // is not seen to have stopped short, and a second solve would only cost time.
  if (rational.ok && fit_rms(pr, rational, views) <= fit_rms(pr, plumb_bob, views)) return rational;
  std::vector<double> intrinsics = plumb_bob.model.intrinsics;
  intrinsics.insert(intrinsics.end(), {0.0, 0.0, 0.0});  // k4 = k5 = k6 = 0: the same projection
  ModelFit g =
      solve_mrcal(pr, views, lens_type_name(LensType::OpenCV8), intrinsics, plumb_bob.poses, false, plumb_bob.warp);
  if (!g.ok || (rational.ok && !(fit_rms(pr, g, views) < fit_rms(pr, rational, views)))) return rational;
  g.solver = "plumb_bob fit + mrcal";
  return g;
}

ModelFit rational_from_wide_profile(const CalibrationProblem& pr, const ViewSubset& views, ModelFit rational,
                                   const ModelFit& wide) {
  if (!pr.solve.use_mrcal || !wide.ok || wide.model.lensmodel != lens_type_name(LensType::KannalaBrandt) ||
      wide.model.intrinsics.size() != 8)
    return rational;
  const double field_deg = corner_field_deg(wide.model, views);
  if (!(field_deg > kRationalFromWideProfileFieldDeg && field_deg < 88)) return rational;
  // Kannala-Brandt's normalised radius at theta off the axis.
  const double* p = wide.model.intrinsics.data();
  const auto radius = [&](double t) {
    const double t2 = t * t;
    return t * (1 + t2 * (p[4] + t2 * (p[5] + t2 * (p[6] + t2 * p[7]))));
  };
  // r_d (1 + k4 r^2 + k5 r^4 + k6 r^6) = r_u (1 + k1 r^2 + k2 r^4 + k3 r^6), r = r_u = tan theta:
  // linear in k1..k6, sampled evenly in theta over the field the corners cover.
  constexpr int kSamples = 200;
  cv::Mat A(kSamples, 6, CV_64F), y(kSamples, 1, CV_64F);
  for (int i = 0; i < kSamples; ++i) {
    const double t = field_deg * M_PI / 180 * (i + 1) / kSamples;
    const double rd = radius(t), ru = std::tan(t), r2 = ru * ru;
    double* a = A.ptr<double>(i);
    a[0] = ru * r2, a[1] = ru * r2 * r2, a[2] = ru * r2 * r2 * r2;
    a[3] = -rd * r2, a[4] = -rd * r2 * r2, a[5] = -rd * r2 * r2 * r2;
    y.at<double>(i) = rd - ru;
  }
  cv::Mat c;
  if (!cv::solve(A, y, c, cv::DECOMP_SVD)) return rational;
  const std::vector<double> seed = {p[0],           p[1],           p[2],           p[3],
                                    c.at<double>(0), c.at<double>(1), 0,             0,
                                    c.at<double>(2), c.at<double>(3), c.at<double>(4), c.at<double>(5)};
  for (double v : seed)
    if (!std::isfinite(v)) return rational;
  ModelFit g = solve_mrcal(pr, views, lens_type_name(LensType::OpenCV8), seed, wide.poses, false, wide.warp);
  if (!g.ok || (rational.ok && !(fit_rms(pr, g, views) < fit_rms(pr, rational, views)))) return rational;
  g.solver = "Kannala-Brandt fit's radial profile + mrcal";
  return g;
}

ModelFit refine_seed(const CalibrationProblem& pr, const ViewSubset& views, LensType type, const ModelFit& seed) {
  if (!seed.ok) return seed;
  switch (type) {
    case LensType::KannalaBrandt:
      return refine_kannala_brandt(pr, views, seed);
    case LensType::OmnidirMei:
      return refine_mei(pr, views, seed);
    case LensType::Stereographic:
    case LensType::SplinedStereographic: {
      ModelFit f = solve_mrcal(pr, views, seed.model.lensmodel, seed.model.intrinsics, seed.poses,
                               type == LensType::SplinedStereographic, seed.warp);
      if (f.ok) f.solver = seed.solver + " + mrcal";
      return f;
    }
    default:
      return polish(pr, views, seed);
  }
}

WideField wide_fit_field(const CalibrationProblem& pr, CandidateSolver& solver, double max_rms_px) {
  WideField w;
  double best = max_rms_px;
  const ModelFit* by = nullptr;
  for (LensType t : {LensType::KannalaBrandt, LensType::OmnidirMei})
    if (const ModelFit& f = solver.get(t); f.ok)
      if (const double rms = fit_rms(pr, f, solver.views()); rms <= best) {
        best = rms;
        by = &f;
        w.seen_by = t;
      }
  if (by) w.deg = corner_field_deg(by->model, solver.views());
  return w;
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
