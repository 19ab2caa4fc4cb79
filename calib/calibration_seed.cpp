#include "calib/calibration_seed.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <opencv2/calib3d.hpp>
#include <opencv2/ccalib/omnidir.hpp>  // the CALIB_ numbers; the call is calib/omnidir_plugin.h

#include "calib/omnidir_plugin.h"

namespace lp {

namespace {

cv::Vec3d board_vec(const BoardSpec& b, int k) {
  const auto p = board_point(b, k);
  return {p[0], p[1], p[2]};
}

// cv::fisheye's and cv::omnidir's poses of views with corners near or beyond 90 deg can be
// far off even when their intrinsics are good: every view is re-posed under the seed
// intrinsics (PnP on the rays + pixel refinement) and keeps whichever pose fits it better.
// Views OpenCV did not pose must be posed here; false (error set) when one cannot be.
bool repose_views(const CalibrationProblem& pr, const ViewSubset& views, const std::vector<char>& has_pose,
                  ModelFit& f, int* reposed, const std::string& seed_name) {
  for (size_t i = 0; i < views.size(); ++i) {
    const auto p = solve_pose(pr, f.model, f.warp, *views[i]);
    if (!has_pose[i] && !p) {
      f.error = "cannot pose a view under the " + seed_name + " seed";
      return false;
    }
    if (p && (!has_pose[i] || view_squared_error(pr, f.model, f.warp, *views[i], *p) <
                                  view_squared_error(pr, f.model, f.warp, *views[i], f.poses[i]))) {
      f.poses[i] = *p;
      ++*reposed;
    }
  }
  return true;
}

SeedReport seed_kannala_brandt(const CalibrationProblem& pr, const ViewSubset& views, const SeedOptions& o) {
  SeedReport s;
  std::vector<char> has_pose;
  s.fit = opencv_fisheye(pr, views, [](const std::array<double, 2>&) { return true; }, &has_pose,
                         o.fisheye_iterations);
  if (!s.fit.ok) {
    const double cx = (pr.width - 1) / 2.0, cy = (pr.height - 1) / 2.0;
    const double rmax = o.kb_central_radius * std::min(pr.width, pr.height);
    s.fit = opencv_fisheye(
        pr, views, [&](const std::array<double, 2>& q) { return std::hypot(q[0] - cx, q[1] - cy) < rmax; },
        &has_pose, o.fisheye_iterations);
    s.central_corners_only = true;
    if (!s.fit.ok) return s;
    s.fit.solver += ", central corners";
  }
  if (!repose_views(pr, views, has_pose, s.fit, &s.views_reposed, "Kannala-Brandt")) s.fit.ok = false;
  return s;
}

// Mei from a solved Kannala-Brandt fit of the same views, without cv::omnidir: the same
// core and poses, and the xi, focal length and k1, k2 whose radial profile is closest to
// Kannala-Brandt's over the angles the corners are seen at. Under Kannala-Brandt a ray at
// theta lands at radius fx d(theta), d = theta (1 + k1 theta^2 + ... + k4 theta^8); under Mei
// at fx' (m + k1' m^3 + k2' m^5), m = sin theta / (cos theta + xi). For each xi of a grid the
// rest is linear: d = a m + b m^3 + c m^5, fx' = a fx, k1' = b / a, k2' = c / a. nullopt when
// the corners' angles cannot pin the three down.
std::optional<ModelFit> mei_from_kannala_brandt(const CalibrationProblem& pr, const ViewSubset& views,
                                                const ModelFit& kb) {
  const auto& in = kb.model.intrinsics;
  if (in.size() != 8 || kb.poses.size() != views.size()) return std::nullopt;
  const std::vector<double> thetas = posed_corner_angles(pr, views, kb);
  if (thetas.size() < 12) return std::nullopt;
  std::vector<double> d(thetas.size());
  for (size_t j = 0; j < thetas.size(); ++j) {
    const double th = thetas[j], t2 = th * th;
    d[j] = th * (1 + t2 * (in[4] + t2 * (in[5] + t2 * (in[6] + t2 * in[7]))));
  }
  double best_residual = HUGE_VAL;
  std::array<double, 4> best{};  // xi, a, b, c
  for (int step = 0; step <= 60; ++step) {  // xi 0 ... 3 by 0.05: catadioptric ~1, fisheyes 1-2
    const double xi = 0.05 * step;
    cv::Matx33d A = cv::Matx33d::zeros();
    cv::Vec3d y(0, 0, 0);
    for (size_t j = 0; j < thetas.size(); ++j) {
      const double w = std::cos(thetas[j]) + xi;
      if (!(w > 1e-6)) continue;  // beyond what this xi can image
      const double m = std::sin(thetas[j]) / w, m2 = m * m;
      const cv::Vec3d f(m, m * m2, m * m2 * m2);
      A += f * f.t();
      y += d[j] * f;
    }
    cv::Vec3d x;
    if (!cv::solve(A, y, x, cv::DECOMP_CHOLESKY) || !(x[0] > 0)) continue;
    double residual = 0;
    for (size_t j = 0; j < thetas.size(); ++j) {
      const double w = std::cos(thetas[j]) + xi;
      const double m = w > 1e-6 ? std::sin(thetas[j]) / w : 1e6, m2 = m * m;
      const double e = d[j] - (x[0] * m + x[1] * m * m2 + x[2] * m * m2 * m2);
      residual += e * e;
    }
    if (residual < best_residual) best_residual = residual, best = {xi, x[0], x[1], x[2]};
  }
  if (!(best[1] > 0) || !std::isfinite(best_residual)) return std::nullopt;
  ModelFit f;
  f.model = make_model(pr, lens_type_name(LensType::OmnidirMei),
                       {best[1] * in[0], best[1] * in[1], in[2], in[3], best[0], best[2] / best[1], best[3] / best[1], 0, 0});
  f.poses = kb.poses;
  f.warp = kb.warp;
  f.params = 9;
  f.solver = "Kannala-Brandt fit";
  f.ok = true;
  return f;
}

SeedReport seed_mei(const CalibrationProblem& pr, const ViewSubset& views, const SolvedFit& solved,
                    const SeedOptions& options) {
  SeedReport s;
  // From the Kannala-Brandt fit where it describes the lens (SolveOptions::
  // mei_from_kannala_brandt): no cv::omnidir, whose plugin alone loads 160 libraries (its
  // highgui's Qt among them: 0.15-0.4 s) and whose own solver walks xi's valley on narrow
  // lenses. Catadioptric lenses, which Kannala-Brandt fits poorly (its poses then mislead),
  // keep cv::omnidir.
  if (pr.solve.mei_from_kannala_brandt) {
    const ModelFit& kb = solved(LensType::KannalaBrandt);
    if (kb.ok && fit_rms(pr, kb, views) <= kMeiFromKannalaBrandtRmsPx)
      if (auto f = mei_from_kannala_brandt(pr, views, kb)) {
        s.fit = *f;
        return s;
      }
  }
  if (options.mei_unit_xi) {
    s.fit = mei_unit_xi_seed(pr, views);
    if (s.fit.ok) return s;
  }
  std::vector<char> has_pose;
  // 30 iterations of cv::omnidir's own solver, not 300: this is a seed, which the Ceres
  // refinement (refine_joint) takes to convergence. On narrow lenses (stereo, Ladybug) xi is
  // barely observable and cv::omnidir walked its valley for all 300 iterations, a quarter of
  // the automatic choice's CPU. At 30 (or 10) every shared set chooses the same model, every
  // candidate's RMS, held-out RMS and cross-validation stay within 1e-5 relative, and the
  // chosen models' intrinsics within 4e-6 (Mei ends where its flat valley lets it).
  s.fit = opencv_omnidir(pr, views, &has_pose, 30);
  if (!s.fit.ok) return s;
  if (!repose_views(pr, views, has_pose, s.fit, &s.views_reposed, "cv::omnidir")) s.fit.ok = false;
  // cv::omnidir's answer differs in its last digits (~1e-14 relative) when it runs on another
  // thread; rounded well above that, the seed, and so Mei's fit and the fits seeded from it
  // (stereographic, splined), are the same bits on every thread (the spline carried 1e-14 at
  // the seed to 2e-8 in its cross-validation on the 190 deg synthetic views).
  if (s.fit.ok) s.fit = rounded_seed(s.fit);
  return s;
}

// The core and poses of Mei's fit where it fits the views, else Kannala-Brandt's, else the
// pinhole fit's. On the catadioptric sets Kannala-Brandt fails or misses the corners by
// metres of pixels, and a stereographic fit from the pinhole's poses (or those) ran mrcal to
// its 300 iterations, 5.6-12 px off, and the splined fit after it too (0.4 s of KaidanOmni's
// 1.1); asking Mei first also spares the wait for that misfit (MiniOmni: 0.18 s on the
// candidate stage's critical path). Where both fit, the stereographic fit ends at the same
// minimum from either (the shared sets' numbers within 5.3e-7 relative). Mei's focal length is
// scaled to the stereographic one that images the centre alike: r = f theta / (1 + xi)
// against f' theta.
SeedReport seed_stereographic(const CalibrationProblem& pr, const ViewSubset& views, const SolvedFit& solved) {
  SeedReport s;
  const auto fits = [&](const ModelFit& f) { return f.ok && fit_rms(pr, f, views) <= kStereographicSeedRmsPx; };
  const ModelFit* from = nullptr;
  double scale = 1;
  if (const ModelFit& mei = solved(LensType::OmnidirMei); fits(mei) && mei.model.intrinsics.size() > 4) {
    from = &mei;
    scale = 1 / (1 + mei.model.intrinsics[4]);
  } else {
    from = &solved(LensType::KannalaBrandt);
    if (!from->ok) from = &solved(LensType::Pinhole);
  }
  if (!from->ok) {
    s.fit.error = "no seed (Kannala-Brandt, Mei and pinhole fits failed)";
    return s;
  }
  std::vector<double> core(from->model.intrinsics.begin(), from->model.intrinsics.begin() + 4);
  core[0] *= scale;
  core[1] *= scale;
  s.fit.model = make_model(pr, lens_type_name(LensType::Stereographic), core);
  s.fit.poses = from->poses;
  s.fit.params = 4;
  s.fit.solver = from->model.lensmodel + " fit";
  s.fit.ok = true;
  return s;
}

SeedReport seed_splined(const CalibrationProblem& pr, const SolvedFit& solved, const SeedOptions& o) {
  SeedReport s;
  const ModelFit& st = solved(LensType::Stereographic);
  if (!st.ok) {
    s.fit.error = "no seed (stereographic fit failed)";
    return s;
  }
  // A zero spline is exactly the stereographic seed. Field of view: the widest horizontal
  // angle of the image under the seed, with a margin.
  const auto& c = st.model.intrinsics;
  const double u = std::max(c[2] + 0.5, pr.width - 0.5 - c[2]) / c[0];
  const double half = 2 * std::atan(u / 2);
  const int fov = std::min(359, int(std::ceil(2 * half * 180 / M_PI * o.spline_fov_margin)));
  const SolveOptions& so = pr.solve;
  const std::string lm = splined_stereographic_name(so.spline_order, so.spline_nx, so.spline_ny, fov);
  const std::optional<LensModel> lens = LensModel::try_parse(lm);
  if (!lens || lens->param_count() < 4) {
    s.fit.error = "mrcal rejects " + lm;
    return s;
  }
  std::vector<double> seed(size_t(lens->param_count()), 0.0);
  std::copy(c.begin(), c.begin() + 4, seed.begin());
  s.fit.model = make_model(pr, lm, seed);
  s.fit.poses = st.poses;
  s.fit.params = lens->param_count();
  s.fit.solver = "stereographic fit";
  s.fit.ok = true;
  return s;
}

}  // namespace

ModelFit mei_unit_xi_seed(const CalibrationProblem& pr, const ViewSubset& views, size_t probe_views) {
  const double cx = (pr.width - 1) / 2.0, cy = (pr.height - 1) / 2.0;
  const ViewSubset probe = evenly_spaced(views, std::max<size_t>(1, probe_views));
  const auto with_gamma = [&](double gamma) {
    ModelFit f;
    f.model = make_model(pr, lens_type_name(LensType::OmnidirMei), {gamma, gamma, cx, cy, 1, 0, 0, 0, 0});
    f.params = 9;
    f.solver = "unit-xi search";
    f.ok = true;
    return f;
  };
  const auto cost = [&](double log_gamma) { return heldout_rms(pr, with_gamma(std::exp(log_gamma)), probe); };
  double r_max = 0;
  for (const BoardView* v : probe)
    for (size_t k = 0; k < v->px.size(); ++k)
      if (v->inlier[k]) r_max = std::max(r_max, std::hypot(v->px[k][0] - cx, v->px[k][1] - cy));
  ModelFit f;
  f.error = "no generalised focal length poses the views at xi = 1";
  if (!(r_max > 0)) return f;
  const double step = std::log(2.0);
  double best_x = 0, best = HUGE_VAL;
  for (double x = std::log(0.2 * r_max); x <= std::log(16 * r_max) + 1e-9; x += step)
    if (const double c = cost(x); c < best) best = c, best_x = x;
  if (!std::isfinite(best)) return f;
  // Golden section on [best - step, best + step]: its two first points and 4 steps narrow it
  // to 0.18 of a grid step, ample for a seed the joint refinement takes to convergence.
  const double phi = (std::sqrt(5.0) - 1) / 2;
  double a = best_x - step, b = best_x + step;
  double x1 = b - phi * (b - a), x2 = a + phi * (b - a), c1 = cost(x1), c2 = cost(x2);
  for (int it = 0; it < 4; ++it) {
    if (c1 < c2) {
      b = x2, x2 = x1, c2 = c1;
      x1 = b - phi * (b - a), c1 = cost(x1);
    } else {
      a = x1, x1 = x2, c1 = c2;
      x2 = a + phi * (b - a), c2 = cost(x2);
    }
  }
  const double x = std::min({c1, c2, best}) == best ? best_x : c1 < c2 ? x1 : x2;
  f = with_gamma(std::exp(x));
  f.poses.assign(views.size(), BoardPose{});
  const std::vector<char> unposed(views.size(), 0);
  int reposed = 0;
  if (!repose_views(pr, views, unposed, f, &reposed, "unit-xi")) f.ok = false;
  return f;
}

ModelFit opencv_fisheye(const CalibrationProblem& pr, const ViewSubset& views,
                        const std::function<bool(const std::array<double, 2>&)>& use, std::vector<char>* has_pose,
                        int max_iterations) {
  ModelFit f;
  f.solver = "cv::fisheye";
  std::vector<cv::Mat> obj, img;
  has_pose->assign(views.size(), 0);
  for (size_t vi = 0; vi < views.size(); ++vi) {
    const BoardView* v = views[vi];
    std::vector<cv::Vec3d> o;
    std::vector<cv::Vec2d> q;
    for (size_t k = 0; k < v->px.size(); ++k)
      if (v->inlier[k] && use(v->px[k])) {
        o.push_back(board_vec(pr.board, int(k)));
        q.push_back({v->px[k][0], v->px[k][1]});
      }
    if (o.size() < 6) continue;
    (*has_pose)[vi] = 1;
    obj.push_back(cv::Mat(o, true).reshape(3, int(o.size())));
    img.push_back(cv::Mat(q, true).reshape(2, int(q.size())));
  }
  cv::Matx33d K;
  cv::Vec4d D;
  std::vector<cv::Vec3d> rv, tv;
  try {
    cv::fisheye::calibrate(obj, img, cv::Size(pr.width, pr.height), K, D, rv, tv,
                           cv::fisheye::CALIB_RECOMPUTE_EXTRINSIC | cv::fisheye::CALIB_FIX_SKEW,
                           cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, max_iterations, 1e-14));
  } catch (const cv::Exception& e) {
    f.error = "cv::fisheye::calibrate failed";
    return f;
  }
  f.model = make_model(pr, lens_type_name(LensType::KannalaBrandt),
                       {K(0, 0), K(1, 1), K(0, 2), K(1, 2), D[0], D[1], D[2], D[3]});
  f.poses.assign(views.size(), BoardPose{});
  for (size_t i = 0, j = 0; i < views.size(); ++i)
    if ((*has_pose)[i]) {
      f.poses[i] = {rv[j][0], rv[j][1], rv[j][2], tv[j][0], tv[j][1], tv[j][2]};
      ++j;
    }
  for (double x : f.model.intrinsics)
    if (!std::isfinite(x)) {
      f.error = "cv::fisheye::calibrate diverged";
      return f;
    }
  f.ok = true;
  f.params = 8;
  return f;
}

ModelFit opencv_calibrate_camera(const CalibrationProblem& pr, const ViewSubset& views, LensType type, bool lu_steps) {
  // Flags and the number of OpenCV coefficients kept (k1 k2 p1 p2 k3 [k4 k5 k6]).
  int flags = 0, ndist = 0;
  if (type == LensType::Pinhole) {
    flags = cv::CALIB_FIX_K1 | cv::CALIB_FIX_K2 | cv::CALIB_FIX_K3 | cv::CALIB_ZERO_TANGENT_DIST;
  } else if (type == LensType::OpenCV5) {
    ndist = 5;
  } else if (type == LensType::OpenCV8) {
    flags = cv::CALIB_RATIONAL_MODEL;
    ndist = 8;
  } else {
    ModelFit f;
    f.error = lens_type_name(type) + " is not a cv::calibrateCamera candidate";
    return f;
  }
  ModelFit f;
  f.solver = "cv::calibrateCamera";
  std::vector<std::vector<cv::Point3f>> obj;
  std::vector<std::vector<cv::Point2f>> img;
  for (const BoardView* v : views) {
    obj.emplace_back();
    img.emplace_back();
    for (size_t k = 0; k < v->px.size(); ++k)
      if (v->inlier[k]) {
        const auto b = board_point(pr.board, int(k));
        obj.back().push_back(cv::Point3f(float(b[0]), float(b[1]), float(b[2])));
        img.back().push_back(cv::Point2f(float(v->px[k][0]), float(v->px[k][1])));
      }
  }
  cv::Mat K, D;
  std::vector<cv::Mat> rv, tv;
  // Each Levenberg-Marquardt step solved by LU, not SVD (OpenCV's default): the damped normal
  // equations are small and positive definite, and the SVD (ATLAS's LAPACK, ~4 ms a step at
  // 15 views) was a third of the automatic choice's CPU. fisheye1's rational seed 0.42 ->
  // 0.09 s, and it no longer lands on another point of its flat valley in one run of five
  // when the solves share the cores; every choice is unchanged (docs/calibration.md, stop 39).
  if (lu_steps) flags |= cv::CALIB_USE_LU;
  try {
    cv::calibrateCamera(obj, img, cv::Size(pr.width, pr.height), K, D, rv, tv, flags,
                        cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-12));
  } catch (const cv::Exception&) {
    f.error = "cv::calibrateCamera failed";
    return f;
  }
  std::vector<double> in = {K.at<double>(0, 0), K.at<double>(1, 1), K.at<double>(0, 2), K.at<double>(1, 2)};
  for (int i = 0; i < ndist; ++i) in.push_back(i < int(D.total()) ? D.at<double>(i) : 0.0);
  f.model = make_model(pr, lens_type_name(type), in);
  for (size_t i = 0; i < views.size(); ++i)
    f.poses.push_back({rv[i].at<double>(0), rv[i].at<double>(1), rv[i].at<double>(2), tv[i].at<double>(0),
                       tv[i].at<double>(1), tv[i].at<double>(2)});
  for (double x : in)
    if (!std::isfinite(x)) {
      f.error = "cv::calibrateCamera diverged";
      return f;
    }
  f.ok = true;
  f.params = 4 + ndist;
  return f;
}

ModelFit opencv_omnidir(const CalibrationProblem& pr, const ViewSubset& views, std::vector<char>* has_pose_out,
                        int max_iterations) {
  ModelFit f;
  f.solver = "cv::omnidir";
  std::vector<cv::Mat> obj, img;
  std::vector<int> vmap;  // omnidir input index -> subset index
  for (size_t vi = 0; vi < views.size(); ++vi) {
    const BoardView* v = views[vi];
    std::vector<cv::Vec3d> o;
    std::vector<cv::Vec2d> q;
    for (size_t k = 0; k < v->px.size(); ++k)
      if (v->inlier[k]) {
        o.push_back(board_vec(pr.board, int(k)));
        q.push_back({v->px[k][0], v->px[k][1]});
      }
    if (o.size() < 6) continue;
    vmap.push_back(int(vi));
    obj.push_back(cv::Mat(o, true).reshape(3, 1));
    img.push_back(cv::Mat(q, true).reshape(2, 1));
  }
  cv::Mat K, xi, D, idx;
  std::vector<cv::Mat> rv, tv;
  try {
    detail::omnidir_calibrate(obj, img, cv::Size(pr.width, pr.height), K, xi, D, rv, tv, cv::omnidir::CALIB_FIX_SKEW,
                           cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, max_iterations, 1e-10), idx);
  } catch (const cv::Exception&) {
    f.error = "cv::omnidir::calibrate failed";
    return f;
  }
  if (K.empty() || xi.empty() || D.total() < 4 || idx.empty() || rv.size() != idx.total()) {
    f.error = "cv::omnidir::calibrate found no solution";
    return f;
  }
  K.convertTo(K, CV_64F);
  xi.convertTo(xi, CV_64F);
  D.convertTo(D, CV_64F);
  idx.convertTo(idx, CV_32S);
  f.model = make_model(pr, lens_type_name(LensType::OmnidirMei),
                       {K.at<double>(0, 0), K.at<double>(1, 1), K.at<double>(0, 2), K.at<double>(1, 2),
                        xi.at<double>(0), D.at<double>(0), D.at<double>(1), D.at<double>(2), D.at<double>(3)});
  for (double x : f.model.intrinsics)
    if (!std::isfinite(x)) {
      f.error = "cv::omnidir::calibrate diverged";
      return f;
    }
  std::vector<char>& has_pose = *has_pose_out;
  has_pose.assign(views.size(), 0);
  f.poses.assign(views.size(), BoardPose{});
  for (size_t j = 0; j < idx.total(); ++j) {
    const int in = idx.at<int>(int(j));
    if (in < 0 || in >= int(vmap.size())) continue;
    cv::Mat r, t;
    rv[j].convertTo(r, CV_64F);
    tv[j].convertTo(t, CV_64F);
    const int vi = vmap[in];
    f.poses[vi] = {r.at<double>(0), r.at<double>(1), r.at<double>(2), t.at<double>(0), t.at<double>(1),
                   t.at<double>(2)};
    has_pose[vi] = 1;
  }
  f.ok = true;
  f.params = 9;
  return f;
}

ModelFit rounded_seed(const ModelFit& raw) {
  // cv::calibrateCamera is not repeatable: the same call on the same corners in one process
  // differs in the last digits now and then (measured: 1 of 5 calls). mrcal's polish is, so
  // it starts from the seed rounded to well above that noise and no longer carries it.
  ModelFit seed = raw;
  auto round_to = [](double x, double q) { return std::nearbyint(x / q) * q; };
  for (size_t i = 0; i < seed.model.intrinsics.size(); ++i)
    seed.model.intrinsics[i] = round_to(seed.model.intrinsics[i], i < 4 ? 1e-3 : 1e-5);
  for (BoardPose& p : seed.poses)
    for (int k = 0; k < 6; ++k) p[k] = round_to(p[k], k < 3 ? 1e-6 : 1e-3);
  return seed;
}

SeedReport seed_candidate(const CalibrationProblem& pr, const ViewSubset& views, LensType type,
                          const SolvedFit& solved, const SeedOptions& options) {
  switch (type) {
    case LensType::KannalaBrandt:
      return seed_kannala_brandt(pr, views, options);
    case LensType::OmnidirMei:
      return seed_mei(pr, views, solved, options);
    case LensType::Pinhole:
    case LensType::OpenCV5:
    case LensType::OpenCV8:
      return SeedReport{opencv_calibrate_camera(pr, views, type)};
    case LensType::Stereographic:
    case LensType::SplinedStereographic: {
      if (!pr.solve.use_mrcal) {
        SeedReport s;
        s.fit.error = "needs mrcal (use_mrcal = false)";
        return s;
      }
      return type == LensType::Stereographic ? seed_stereographic(pr, views, solved)
                                              : seed_splined(pr, solved, options);
    }
    default: {
      SeedReport s;
      s.fit.error = "unknown candidate";
      return s;
    }
  }
}

}  // namespace lp
