#include "calib/geometric.h"

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <numeric>
#include <opencv2/calib3d.hpp>
#include <opencv2/ccalib/omnidir.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <random>

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include "calib/mrcal_solve.h"
#include "core/error.h"

namespace lp {
namespace {

constexpr const char* kPinhole = "LENSMODEL_PINHOLE";
constexpr const char* kStereo = "LENSMODEL_STEREOGRAPHIC";
constexpr const char* kPlumbBob = "plumb_bob";
constexpr const char* kKB = "LENSMODEL_KANNALA_BRANDT";
constexpr const char* kOpenCV8 = "LENSMODEL_OPENCV8";
constexpr const char* kSplined = "LENSMODEL_SPLINED_STEREOGRAPHIC";
constexpr const char* kMei = "LENSMODEL_OMNIDIR_MEI";

const std::vector<std::string>& all_candidates() {
  static const std::vector<std::string> names = {kPinhole, kStereo, kPlumbBob, kKB, kOpenCV8, kSplined, kMei};
  return names;
}

using Pose = std::array<double, 6>;  // board -> camera: Rodrigues r, t (mm)

struct View {
  int index = 0;  // as given
  std::vector<std::array<double, 2>> px;
  std::vector<char> inlier;
};
using Subset = std::vector<const View*>;

struct Fit {
  bool ok = false;
  std::string error;
  CameraModel model;
  std::vector<Pose> poses;  // per view of the subset
  int params = 0;
};

struct Problem {
  BoardSpec board;
  int width = 0, height = 0;
  CalibrateOptions options;
};

cv::Point3d board_point(const BoardSpec& b, int k) {
  return {(k % b.cols) * b.square_mm, (k / b.cols) * b.square_mm, 0.0};
}

// Camera-frame points of a view's board corners.
std::vector<Vec3> board_in_camera(const Problem& pr, const Pose& p) {
  cv::Matx33d R;
  cv::Rodrigues(cv::Vec3d(p[0], p[1], p[2]), R);
  const int n = pr.board.cols * pr.board.rows;
  std::vector<Vec3> out(n);
  for (int k = 0; k < n; ++k) {
    const cv::Vec3d X = R * cv::Vec3d(board_point(pr.board, k)) + cv::Vec3d(p[3], p[4], p[5]);
    out[k] = {X[0], X[1], X[2]};
  }
  return out;
}

// observed - projected per corner; NaN where the model cannot image the corner.
std::vector<std::array<double, 2>> view_residuals(const Problem& pr, const CameraModel& m, const View& v,
                                                  const Pose& pose) {
  const auto P = board_in_camera(pr, pose);
  std::vector<std::array<double, 2>> r(P.size());
  for (size_t k = 0; k < P.size(); ++k) {
    const auto q = project(m, P[k]);
    if (q)
      r[k] = {v.px[k][0] - q->x, v.px[k][1] - q->y};
    else
      r[k] = {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN()};
  }
  return r;
}

double rms_of(const std::vector<double>& sq) {
  if (sq.empty()) return 0;
  return std::sqrt(std::accumulate(sq.begin(), sq.end(), 0.0) / double(sq.size()));
}

// RMS (2-D) of a fit over the inliers of its subset; +inf when a corner cannot be imaged.
double fit_rms(const Problem& pr, const Fit& f, const Subset& views) {
  std::vector<double> sq;
  for (size_t i = 0; i < views.size(); ++i) {
    const auto r = view_residuals(pr, f.model, *views[i], f.poses[i]);
    for (size_t k = 0; k < r.size(); ++k)
      if (views[i]->inlier[k]) {
        const double e = r[k][0] * r[k][0] + r[k][1] * r[k][1];
        sq.push_back(std::isfinite(e) ? e : 1e12);
      }
  }
  return rms_of(sq);
}

CameraModel make_model(const Problem& pr, const std::string& lensmodel, std::vector<double> intrinsics) {
  CameraModel m;
  m.lensmodel = lensmodel;
  m.intrinsics = std::move(intrinsics);
  m.width = pr.width;
  m.height = pr.height;
  return m;
}

// ---- OpenCV solvers -------------------------------------------------------------------

// cv::fisheye::calibrate over the inlier corners that `use` accepts; views with fewer
// than 6 such corners get no pose (empty optional).
Fit fit_opencv_kb(const Problem& pr, const Subset& views, const std::function<bool(const std::array<double, 2>&)>& use,
                  std::vector<char>* has_pose) {
  Fit f;
  std::vector<cv::Mat> obj, img;
  has_pose->assign(views.size(), 0);
  for (size_t vi = 0; vi < views.size(); ++vi) {
    const View* v = views[vi];
    std::vector<cv::Vec3d> o;
    std::vector<cv::Vec2d> q;
    for (size_t k = 0; k < v->px.size(); ++k)
      if (v->inlier[k] && use(v->px[k])) {
        o.push_back(cv::Vec3d(board_point(pr.board, int(k))));
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
                           cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 200, 1e-14));
  } catch (const cv::Exception& e) {
    f.error = "cv::fisheye::calibrate failed";
    return f;
  }
  f.model = make_model(pr, kKB, {K(0, 0), K(1, 1), K(0, 2), K(1, 2), D[0], D[1], D[2], D[3]});
  f.poses.assign(views.size(), Pose{});
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

// cv::calibrateCamera; flags select pinhole / plumb_bob / rational. Returns the OpenCV
// coefficients (k1 k2 p1 p2 k3 [k4 k5 k6]) in `dist`.
Fit fit_opencv_pinhole_family(const Problem& pr, const Subset& views, int flags, const std::string& lensmodel,
                              int ndist) {
  Fit f;
  std::vector<std::vector<cv::Point3f>> obj;
  std::vector<std::vector<cv::Point2f>> img;
  for (const View* v : views) {
    obj.emplace_back();
    img.emplace_back();
    for (size_t k = 0; k < v->px.size(); ++k)
      if (v->inlier[k]) {
        obj.back().push_back(cv::Point3f(board_point(pr.board, int(k))));
        img.back().push_back(cv::Point2f(float(v->px[k][0]), float(v->px[k][1])));
      }
  }
  cv::Mat K, D;
  std::vector<cv::Mat> rv, tv;
  try {
    cv::calibrateCamera(obj, img, cv::Size(pr.width, pr.height), K, D, rv, tv, flags,
                        cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-12));
  } catch (const cv::Exception&) {
    f.error = "cv::calibrateCamera failed";
    return f;
  }
  std::vector<double> in = {K.at<double>(0, 0), K.at<double>(1, 1), K.at<double>(0, 2), K.at<double>(1, 2)};
  for (int i = 0; i < ndist; ++i) in.push_back(i < int(D.total()) ? D.at<double>(i) : 0.0);
  f.model = make_model(pr, lensmodel, in);
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


std::optional<Pose> solve_pose(const Problem& pr, const CameraModel& m, const View& v);
Fit refine_kb(const Problem& pr, const Subset& views, const Fit& seed);
Fit refine_mei(const Problem& pr, const Subset& views, const Fit& seed);

// Kannala-Brandt reprojection of one corner (the projection of camera_model.cpp: theta
// from atan2, so rays beyond 90 deg work, unlike cv::fisheye).
struct KannalaBrandtCost {
  double X, Y, qx, qy;
  template <typename T>
  bool operator()(const T* in, const T* pose, T* r) const {
    const T P[3] = {T(X), T(Y), T(0)};
    T C[3];
    ceres::AngleAxisRotatePoint(pose, P, C);
    C[0] += pose[3];
    C[1] += pose[4];
    C[2] += pose[5];
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
    r[0] = in[0] * s * C[0] + in[2] - T(qx);
    r[1] = in[1] * s * C[1] + in[3] - T(qy);
    return true;
  }
};

// Kannala-Brandt: cv::fisheye::calibrate as the seed (all corners; when it fails, the
// corners of the central part of the image, other views posed by PnP through the seed),
// then every inlier corner in one joint least-squares solve (Ceres, single-threaded).
Fit fit_kb(const Problem& pr, const Subset& views) {
  std::vector<char> has_pose;
  Fit seed = fit_opencv_kb(pr, views, [](const std::array<double, 2>&) { return true; }, &has_pose);
  if (!seed.ok) {
    const double cx = (pr.width - 1) / 2.0, cy = (pr.height - 1) / 2.0, rmax = 0.45 * std::min(pr.width, pr.height);
    seed = fit_opencv_kb(
        pr, views, [&](const std::array<double, 2>& q) { return std::hypot(q[0] - cx, q[1] - cy) < rmax; },
        &has_pose);
    if (!seed.ok) return seed;
  }
  // cv::fisheye's poses of views with corners near or beyond 90 deg can be far off even
  // when its intrinsics are good: every view is re-posed under the seed intrinsics
  // (PnP on the rays + pixel refinement) and keeps whichever pose fits it better.
  for (size_t i = 0; i < views.size(); ++i) {
    auto view_sq = [&](const Pose& p) {
      const auto r = view_residuals(pr, seed.model, *views[i], p);
      double s = 0;
      for (size_t k = 0; k < r.size(); ++k)
        if (views[i]->inlier[k]) s += std::isfinite(r[k][0]) ? r[k][0] * r[k][0] + r[k][1] * r[k][1] : 1e12;
      return s;
    };
    const auto p = solve_pose(pr, seed.model, *views[i]);
    if (!has_pose[i] && !p) {
      seed.ok = false;
      seed.error = "cannot pose a view under the Kannala-Brandt seed";
      return seed;
    }
    if (p && (!has_pose[i] || view_sq(*p) < view_sq(seed.poses[i]))) seed.poses[i] = *p;
  }
  return refine_kb(pr, views, seed);
}

// Joint solve of intrinsics (N of them, cost functor Cost) and poses from `seed`; the
// seed when it fails or does not improve.
template <typename Cost, int N>
Fit refine_joint(const Problem& pr, const Subset& views, const Fit& seed) {
  Fit f = seed;
  ceres::Problem problem;
  for (size_t i = 0; i < views.size(); ++i)
    for (size_t k = 0; k < views[i]->px.size(); ++k) {
      if (!views[i]->inlier[k]) continue;
      const cv::Point3d X = board_point(pr.board, int(k));
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<Cost, 2, N, 6>(
                                   new Cost{X.x, X.y, views[i]->px[k][0], views[i]->px[k][1]}),
                               nullptr, f.model.intrinsics.data(), f.poses[i].data());
    }
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
  if (!finite || summary.final_cost > summary.initial_cost) return seed;
  return f;
}

Fit refine_kb(const Problem& pr, const Subset& views, const Fit& seed) {
  return refine_joint<KannalaBrandtCost, 8>(pr, views, seed);
}

// ---- Mei's unified (omnidirectional) model ---------------------------------------------

// Mei reprojection of one corner, as camera_model.cpp: the point on the unit sphere,
// projected from (0, 0, -xi), radial-tangential distortion (k1 k2 p1 p2), no skew.
struct MeiCost {
  double X, Y, qx, qy;
  template <typename T>
  bool operator()(const T* in, const T* pose, T* r) const {
    const T P[3] = {T(X), T(Y), T(0)};
    T C[3];
    ceres::AngleAxisRotatePoint(pose, P, C);
    C[0] += pose[3];
    C[1] += pose[4];
    C[2] += pose[5];
    const T n = ceres::sqrt(C[0] * C[0] + C[1] * C[1] + C[2] * C[2]);
    const T w = C[2] / n + in[4];
    const T xu = C[0] / n / w, yu = C[1] / n / w;
    const T r2 = xu * xu + yu * yu;
    const T radial = T(1) + in[5] * r2 + in[6] * r2 * r2;
    const T xd = xu * radial + T(2) * in[7] * xu * yu + in[8] * (r2 + T(2) * xu * xu);
    const T yd = yu * radial + in[7] * (r2 + T(2) * yu * yu) + T(2) * in[8] * xu * yu;
    r[0] = in[0] * xd + in[2] - T(qx);
    r[1] = in[1] * yd + in[3] - T(qy);
    return true;
  }
};

Fit refine_mei(const Problem& pr, const Subset& views, const Fit& seed) {
  return refine_joint<MeiCost, 9>(pr, views, seed);
}

// Mei: cv::omnidir::calibrate as the seed (it drops views its initialisation cannot use:
// `idx` maps its poses back; the others are posed by PnP through the seed), every view
// re-posed under the seed when that fits it better, then the joint Ceres solve as for
// Kannala-Brandt.
Fit fit_opencv_omnidir(const Problem& pr, const Subset& views, std::vector<char>* has_pose_out) {
  Fit f;
  std::vector<cv::Mat> obj, img;
  std::vector<int> vmap;  // omnidir input index -> subset index
  for (size_t vi = 0; vi < views.size(); ++vi) {
    const View* v = views[vi];
    std::vector<cv::Vec3d> o;
    std::vector<cv::Vec2d> q;
    for (size_t k = 0; k < v->px.size(); ++k)
      if (v->inlier[k]) {
        o.push_back(cv::Vec3d(board_point(pr.board, int(k))));
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
    cv::omnidir::calibrate(obj, img, cv::Size(pr.width, pr.height), K, xi, D, rv, tv, cv::omnidir::CALIB_FIX_SKEW,
                           cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 300, 1e-10), idx);
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
  f.model = make_model(pr, kMei,
                       {K.at<double>(0, 0), K.at<double>(1, 1), K.at<double>(0, 2), K.at<double>(1, 2),
                        xi.at<double>(0), D.at<double>(0), D.at<double>(1), D.at<double>(2), D.at<double>(3)});
  for (double x : f.model.intrinsics)
    if (!std::isfinite(x)) {
      f.error = "cv::omnidir::calibrate diverged";
      return f;
    }
  std::vector<char>& has_pose = *has_pose_out;
  has_pose.assign(views.size(), 0);
  f.poses.assign(views.size(), Pose{});
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

Fit fit_mei(const Problem& pr, const Subset& views) {
  std::vector<char> has_pose;
  Fit f = fit_opencv_omnidir(pr, views, &has_pose);
  if (!f.ok) return f;
  f.ok = false;
  for (size_t i = 0; i < views.size(); ++i) {
    auto view_sq = [&](const Pose& p) {
      const auto r = view_residuals(pr, f.model, *views[i], p);
      double s = 0;
      for (size_t k = 0; k < r.size(); ++k)
        if (views[i]->inlier[k]) s += std::isfinite(r[k][0]) ? r[k][0] * r[k][0] + r[k][1] * r[k][1] : 1e12;
      return s;
    };
    const auto p = solve_pose(pr, f.model, *views[i]);
    if (!has_pose[i] && !p) {
      f.error = "cannot pose a view under the cv::omnidir seed";
      return f;
    }
    if (p && (!has_pose[i] || view_sq(*p) < view_sq(f.poses[i]))) f.poses[i] = *p;
  }
  f.ok = true;
  f.params = 9;
  return refine_mei(pr, views, f);
}

// ---- mrcal solves, seeded from another fit ---------------------------------------------

Fit fit_mrcal(const Problem& pr, const Subset& views, const std::string& lensmodel, std::vector<double> seed,
              const std::vector<Pose>& poses, bool regularization) {
  Fit f;
  MrcalProblem mp;
  mp.lensmodel = lensmodel;
  mp.intrinsics_seed = std::move(seed);
  mp.poses_seed = poses;
  mp.width = pr.width;
  mp.height = pr.height;
  mp.cols = pr.board.cols;
  mp.rows = pr.board.rows;
  mp.spacing = pr.board.square_mm;
  mp.regularization = regularization;
  for (const View* v : views) {
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
  f.params = int(s.intrinsics.size());
  f.ok = true;
  return f;
}

// Every candidate of one subset of views, fitted on demand, each once.
class Fitter {
 public:
  Fitter(const Problem& pr, Subset views) : pr_(pr), views_(std::move(views)) {}
  const Subset& views() const { return views_; }

  const Fit& get(const std::string& name) {
    auto it = cache_.find(name);
    if (it != cache_.end()) return it->second;
    return adopt(name, compute(name));
  }
  // A fit of `name` on these views made elsewhere (warm-started): used instead of computing one.
  const Fit& adopt(const std::string& name, Fit f) {
    if (f.ok && !std::isfinite(fit_rms(pr_, f, views_))) {
      f.ok = false;
      f.error = "the fit cannot image some corners";
    }
    return cache_.insert_or_assign(name, std::move(f)).first->second;
  }

 private:
  Fit polish(const Fit& raw, const std::string& lensmodel, bool reg) {
    if (!raw.ok || !pr_.options.use_mrcal) return raw;
    // cv::calibrateCamera is not repeatable: the same call on the same corners in one
    // process differs in the last digits now and then (measured: 1 of 5 calls). mrcal's
    // polish is, so it starts from the seed rounded to well above that noise (1e-3 px,
    // 1e-5 per distortion coefficient, 1e-6 rad, 1e-3 mm) and no longer carries it.
    Fit seed = raw;
    auto round_to = [](double x, double q) { return std::nearbyint(x / q) * q; };
    for (size_t i = 0; i < seed.model.intrinsics.size(); ++i)
      seed.model.intrinsics[i] = round_to(seed.model.intrinsics[i], i < 4 ? 1e-3 : 1e-5);
    for (Pose& p : seed.poses)
      for (int k = 0; k < 6; ++k) p[k] = round_to(p[k], k < 3 ? 1e-6 : 1e-3);
    Fit f = fit_mrcal(pr_, views_, lensmodel, seed.model.intrinsics, seed.poses, reg);
    // Keep OpenCV's solution when mrcal fails or does not improve it.
    if (!f.ok || fit_rms(pr_, f, views_) > fit_rms(pr_, raw, views_)) return raw;
    return f;
  }

  Fit compute(const std::string& name) {
    if (name == kKB) return fit_kb(pr_, views_);
    if (name == kMei) return fit_mei(pr_, views_);
    if (name == kPinhole) {
      const int fl = cv::CALIB_FIX_K1 | cv::CALIB_FIX_K2 | cv::CALIB_FIX_K3 | cv::CALIB_ZERO_TANGENT_DIST;
      return polish(fit_opencv_pinhole_family(pr_, views_, fl, kPinhole, 0), kPinhole, false);
    }
    if (name == kPlumbBob)
      return polish(fit_opencv_pinhole_family(pr_, views_, 0, "LENSMODEL_OPENCV5", 5), "LENSMODEL_OPENCV5", false);
    if (name == kOpenCV8)
      return polish(fit_opencv_pinhole_family(pr_, views_, cv::CALIB_RATIONAL_MODEL, kOpenCV8, 8), kOpenCV8, false);
    if (name == kStereo || name == kSplined) {
      Fit f;
      if (!pr_.options.use_mrcal) {
        f.error = "needs mrcal (use_mrcal = false)";
        return f;
      }
      if (name == kStereo) {
        // Seed: the core and poses of the Kannala-Brandt fit (any field of view), else pinhole.
        const Fit* seed = &get(kKB);
        if (!seed->ok) seed = &get(kPinhole);
        if (!seed->ok) {
          f.error = "no seed (Kannala-Brandt and pinhole fits failed)";
          return f;
        }
        std::vector<double> core(seed->model.intrinsics.begin(), seed->model.intrinsics.begin() + 4);
        return fit_mrcal(pr_, views_, kStereo, core, seed->poses, false);
      }
      const Fit& st = get(kStereo);
      if (!st.ok) {
        f.error = "no seed (stereographic fit failed)";
        return f;
      }
      // A zero spline is exactly the stereographic seed. Field of view: the widest
      // horizontal angle of the image under the seed, with a margin.
      const auto& c = st.model.intrinsics;
      const double u = std::max(c[2] + 0.5, pr_.width - 0.5 - c[2]) / c[0];
      const double half = 2 * std::atan(u / 2);
      const int fov = std::min(359, int(std::ceil(2 * half * 180 / M_PI * 1.05)));
      const auto& o = pr_.options;
      const std::string lm = mrcal_splined_name(o.spline_order, o.spline_nx, o.spline_ny, fov);
      const int n = mrcal_model_param_count(lm);
      if (n < 4) {
        f.error = "mrcal rejects " + lm;
        return f;
      }
      std::vector<double> seed(n, 0.0);
      std::copy(c.begin(), c.begin() + 4, seed.begin());
      return fit_mrcal(pr_, views_, lm, seed, st.poses, true);
    }
    Fit f;
    f.error = "unknown candidate";
    return f;
  }

  const Problem& pr_;
  Subset views_;
  std::map<std::string, Fit> cache_;
};

// The fit of `name` on `views` warm-started from a fit on a superset (`poses` aligned
// with `views`): the jackknife's leave-one-out fits converge to the same minimum as a
// cold start, in a fraction of the time. Falls back to a cold start.
Fit warm_refit(const Problem& pr, const Subset& views, const std::string& name, const Fit& from,
               const std::vector<Pose>& poses) {
  Fit seed = from;
  seed.poses = poses;
  if (name == kKB) return refine_kb(pr, views, seed);
  if (name == kMei) return refine_mei(pr, views, seed);
  if (pr.options.use_mrcal) {
    Fit f = fit_mrcal(pr, views, from.model.lensmodel, from.model.intrinsics, poses,
                      from.model.lensmodel.rfind(kSplined, 0) == 0);
    if (f.ok) return f;
  }
  Fitter cold(pr, views);
  return cold.get(name);
}

// ---- poses with fixed intrinsics ----------------------------------------------------

// Pixel residuals of a pose (Levenberg-Marquardt with numeric derivatives).
Pose refine_pose(const Problem& pr, const CameraModel& m, const View& v, Pose p) {
  auto resid = [&](const Pose& q, Eigen::VectorXd& r) {
    const auto rr = view_residuals(pr, m, v, q);
    std::vector<double> out;
    for (size_t k = 0; k < rr.size(); ++k)
      if (v.inlier[k]) {
        out.push_back(std::isfinite(rr[k][0]) ? rr[k][0] : 1e4);
        out.push_back(std::isfinite(rr[k][1]) ? rr[k][1] : 1e4);
      }
    r = Eigen::Map<Eigen::VectorXd>(out.data(), Eigen::Index(out.size()));
  };
  Eigen::VectorXd r;
  resid(p, r);
  double cost = r.squaredNorm(), lambda = 1e-3;
  for (int it = 0; it < 30; ++it) {
    Eigen::MatrixXd J(r.size(), 6);
    for (int j = 0; j < 6; ++j) {
      Pose q = p;
      const double h = j < 3 ? 1e-7 : 1e-6 * std::max(1.0, std::abs(p[j]));
      q[j] += h;
      Eigen::VectorXd rj;
      resid(q, rj);
      J.col(j) = (rj - r) / h;
    }
    const Eigen::MatrixXd A = J.transpose() * J;
    const Eigen::VectorXd g = J.transpose() * r;
    bool improved = false;
    for (int tries = 0; tries < 10 && !improved; ++tries) {
      Eigen::MatrixXd Al = A;
      Al.diagonal() *= (1 + lambda);
      const Eigen::VectorXd d = Al.ldlt().solve(-g);
      Pose q = p;
      for (int j = 0; j < 6; ++j) q[j] += d[j];
      Eigen::VectorXd rq;
      resid(q, rq);
      if (rq.squaredNorm() < cost) {
        const double rel = (cost - rq.squaredNorm()) / std::max(cost, 1e-300);
        p = q;
        r = rq;
        cost = rq.squaredNorm();
        lambda = std::max(lambda / 10, 1e-9);
        improved = true;
        if (rel < 1e-12) return p;
      } else {
        lambda *= 10;
      }
    }
    if (!improved) break;
  }
  return p;
}

// Board pose of a view under fixed intrinsics: PnP on the unprojected rays (normalised
// plane, rays in front of the camera), then refined on pixels. When some rays are not in
// front of the camera (catadioptric and > 180 deg lenses: boards beside or behind it),
// the PnP runs in a frame turned so that the mean ray of the view is its axis.
std::optional<Pose> solve_pose(const Problem& pr, const CameraModel& m, const View& v) {
  std::vector<cv::Point3d> obj;
  std::vector<cv::Vec3d> rays;
  int inliers = 0;
  for (size_t k = 0; k < v.px.size(); ++k) {
    if (!v.inlier[k]) continue;
    ++inliers;
    const auto d = unproject(m, {v.px[k][0], v.px[k][1]});
    if (!d) continue;
    obj.push_back(board_point(pr.board, int(k)));
    rays.push_back({d->x, d->y, d->z});
  }
  auto pnp = [&](const cv::Matx33d& R0) -> std::optional<Pose> {  // R0: camera -> PnP frame
    std::vector<cv::Point3d> o;
    std::vector<cv::Point2d> q;
    for (size_t k = 0; k < rays.size(); ++k) {
      const cv::Vec3d d = R0 * rays[k];
      if (d[2] < 0.1) continue;
      o.push_back(obj[k]);
      q.push_back({d[0] / d[2], d[1] / d[2]});
    }
    if (o.size() < 6) return std::nullopt;
    cv::Vec3d rv, tv;
    try {
      if (!cv::solvePnP(o, q, cv::Matx33d::eye(), cv::noArray(), rv, tv, false, cv::SOLVEPNP_ITERATIVE))
        return std::nullopt;
    } catch (const cv::Exception&) {
      return std::nullopt;
    }
    cv::Matx33d R;
    cv::Rodrigues(rv, R);
    const cv::Matx33d Rc = R0.t() * R;
    const cv::Vec3d tc = R0.t() * tv;
    cv::Vec3d rc;
    cv::Rodrigues(Rc, rc);
    return Pose{rc[0], rc[1], rc[2], tc[0], tc[1], tc[2]};
  };
  std::optional<Pose> p0;
  bool all_front = int(rays.size()) == inliers;
  for (const auto& d : rays) all_front = all_front && d[2] >= 0.1;
  if (all_front) {
    p0 = pnp(cv::Matx33d::eye());
  } else {
    cv::Vec3d mean(0, 0, 0);
    for (const auto& d : rays) mean += d;
    if (cv::norm(mean) < 1e-9) return std::nullopt;
    const cv::Vec3d z = mean / cv::norm(mean);
    // Rotation taking z to (0, 0, 1): rows are an orthonormal frame with z last.
    const cv::Vec3d a = std::abs(z[0]) < 0.9 ? cv::Vec3d(1, 0, 0) : cv::Vec3d(0, 1, 0);
    const cv::Vec3d x = cv::normalize(a.cross(z)), y = z.cross(x);
    const cv::Matx33d R0(x[0], x[1], x[2], y[0], y[1], y[2], z[0], z[1], z[2]);
    p0 = pnp(R0);
  }
  if (!p0) return std::nullopt;
  return refine_pose(pr, m, v, *p0);
}

// RMS of `views`' inlier corners under the intrinsics of `m` with their poses re-solved.
double heldout_rms(const Problem& pr, const CameraModel& m, const Subset& views) {
  std::vector<double> sq;
  for (const View* v : views) {
    const auto pose = solve_pose(pr, m, *v);
    if (!pose) return std::numeric_limits<double>::infinity();
    const auto r = view_residuals(pr, m, *v, *pose);
    for (size_t k = 0; k < r.size(); ++k)
      if (v->inlier[k]) {
        const double e = r[k][0] * r[k][0] + r[k][1] * r[k][1];
        sq.push_back(std::isfinite(e) ? e : 1e12);
      }
  }
  return rms_of(sq);
}

double median_of(std::vector<double> v) {
  if (v.empty()) return 0;
  const size_t n = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + n, v.end());
  double m = v[n];
  if (v.size() % 2 == 0) m = 0.5 * (m + *std::max_element(v.begin(), v.begin() + n));
  return m;
}

std::vector<uint8_t> coverage_mask(const Problem& pr, const Subset& views) {
  cv::Mat mask = cv::Mat::zeros(pr.height, pr.width, CV_8U);
  for (const View* v : views) {
    std::vector<cv::Point2f> pts;
    for (size_t k = 0; k < v->px.size(); ++k)
      if (v->inlier[k]) pts.push_back(cv::Point2f(float(v->px[k][0]), float(v->px[k][1])));
    if (pts.size() < 3) continue;
    std::vector<cv::Point2f> hull;
    cv::convexHull(pts, hull);
    std::vector<cv::Point> ih;
    for (const auto& p : hull) ih.push_back(cv::Point(int(std::lround(p.x)), int(std::lround(p.y))));
    cv::fillConvexPoly(mask, ih, cv::Scalar(255));
  }
  return std::vector<uint8_t>(mask.begin<uint8_t>(), mask.end<uint8_t>());
}

int auto_step(const Problem& pr) {
  if (pr.options.diff_step_px > 0) return pr.options.diff_step_px;
  return std::max(2, int(std::lround(std::sqrt(double(pr.width) * pr.height / 5000.0))));
}

// Balanced splits of n views into two halves (side 0/1 per view): odd/even first, then
// pseudo-random ones from a fixed seed (deterministic), none equal to an earlier one or its
// complement. A split that follows the capture order (first/second half) would put the
// central boards in one half and the rim in the other and measure coverage, not noise.
std::vector<std::vector<int>> balanced_splits(int n, int k) {
  std::vector<std::vector<int>> out;
  std::vector<int> side(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) side[size_t(i)] = i % 2;
  out.push_back(side);
  std::mt19937 rng(12345);
  for (int tries = 0; int(out.size()) < k && tries < 100 * k; ++tries) {
    for (int i = n - 1; i > 0; --i) std::swap(side[size_t(i)], side[size_t(rng() % uint32_t(i + 1))]);
    const bool seen = std::any_of(out.begin(), out.end(), [&](const std::vector<int>& s) {
      bool same = true, complement = true;
      for (size_t i = 0; i < s.size(); ++i) {
        same = same && s[i] == side[i];
        complement = complement && s[i] != side[i];
      }
      return same || complement;
    });
    if (!seen) out.push_back(side);
  }
  return out;
}

// Cross-validation of candidate `name` on one split of `used` (sides from balanced_splits):
// each half refitted warm from `full` (the candidate's fit on every used view), projection
// difference over the covered area. inf when a half has < 3 views, cannot be fitted, or the
// two half-models share no covered pixel.
double split_cross_validation(const Problem& pr, const Subset& used, const std::vector<int>& side,
                              const std::string& name, const Fit& full, const std::vector<uint8_t>& mask, int step) {
  Subset hs[2];
  std::vector<Pose> ps[2];
  for (size_t i = 0; i < used.size(); ++i) {
    hs[side[i]].push_back(used[i]);
    ps[side[i]].push_back(full.poses[i]);
  }
  const double inf = std::numeric_limits<double>::infinity();
  if (hs[0].size() < 3 || hs[1].size() < 3) return inf;
  const Fit a = warm_refit(pr, hs[0], name, full, ps[0]);
  if (!a.ok) return inf;
  const Fit b = warm_refit(pr, hs[1], name, full, ps[1]);
  if (!b.ok) return inf;
  const ProjectionDiff d = projection_difference(a.model, b.model, mask, step);
  return d.samples > 0 ? d.rms_px : inf;
}

// RMS of per-split cross-validations (inf if any is).
double rms_over_splits(const std::vector<double>& v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  double s = 0;
  for (double x : v) s += x * x;
  return std::sqrt(s / double(v.size()));
}

}  // namespace

std::vector<std::vector<int>> balanced_view_splits(int views, int splits) { return balanced_splits(views, splits); }

ProjectionDiff projection_difference(const CameraModel& a, const CameraModel& b, const std::vector<uint8_t>& mask,
                                     int step_px, bool fit_rotation) {
  ProjectionDiff out;
  const int w = a.width, h = a.height, step = std::max(1, step_px);
  std::vector<Vec3> va, vb;
  std::vector<Pixel> qs;
  for (int y = step / 2; y < h; y += step)
    for (int x = step / 2; x < w; x += step) {
      if (!mask.empty() && !mask[size_t(y) * w + x]) continue;
      const Pixel q{double(x), double(y)};
      const auto da = unproject(a, q);
      const auto db = unproject(b, q);
      if (!da || !db) continue;
      va.push_back(*da);
      vb.push_back(*db);
      qs.push_back(q);
    }
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  if (fit_rotation && va.size() >= 3) {
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
    for (size_t i = 0; i < va.size(); ++i)
      H += Eigen::Vector3d(va[i].x, va[i].y, va[i].z) * Eigen::Vector3d(vb[i].x, vb[i].y, vb[i].z).transpose();
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
    const Eigen::Matrix3d U = svd.matrixU(), V = svd.matrixV();
    Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
    S(2, 2) = (V * U.transpose()).determinant() < 0 ? -1 : 1;
    R = V * S * U.transpose();
  }
  std::vector<double> d;
  for (size_t i = 0; i < va.size(); ++i) {
    const Eigen::Vector3d r = R * Eigen::Vector3d(va[i].x, va[i].y, va[i].z);
    const auto p = project(b, {r[0], r[1], r[2]});
    if (!p) continue;
    d.push_back(std::hypot(p->x - qs[i].x, p->y - qs[i].y));
  }
  out.samples = int(d.size());
  if (d.empty()) return out;
  double s = 0;
  for (double x : d) s += x * x;
  out.rms_px = std::sqrt(s / double(d.size()));
  out.max_px = *std::max_element(d.begin(), d.end());
  out.median_px = median_of(d);
  return out;
}

CalibrationResult calibrate(const std::vector<std::vector<std::array<double, 2>>>& corners_per_view,
                            const BoardSpec& board, int width, int height, const CalibrateOptions& options) {
  if (board.cols < 2 || board.rows < 2)
    throw InputError("calibrate: board needs at least 2 inner corners per side (got " + std::to_string(board.cols) +
                     "x" + std::to_string(board.rows) + ")");
  if (!(board.square_mm > 0)) throw InputError("calibrate: board square size must be positive");
  if (width <= 0 || height <= 0) throw InputError("calibrate: image size must be positive");
  const std::vector<std::string> candidates =
      !options.model.empty() ? std::vector<std::string>{options.model}
                             : (options.candidates.empty() ? all_candidates() : options.candidates);
  for (const auto& c : candidates)
    if (std::find(all_candidates().begin(), all_candidates().end(), c) == all_candidates().end())
      throw InputError("calibrate: unknown model '" + c + "'");

  Problem pr{board, width, height, options};
  const int ncorners = board.cols * board.rows;
  std::vector<View> views;
  for (size_t i = 0; i < corners_per_view.size(); ++i) {
    const auto& c = corners_per_view[i];
    if (c.empty()) continue;
    if (int(c.size()) != ncorners)
      throw InputError("calibrate: view " + std::to_string(i) + " has " + std::to_string(c.size()) +
                       " corners, the board has " + std::to_string(ncorners));
    for (const auto& p : c)
      if (!(p[0] >= -0.5 && p[0] <= width - 0.5 && p[1] >= -0.5 && p[1] <= height - 0.5))
        throw InputError("calibrate: view " + std::to_string(i) + " has a corner outside the " +
                         std::to_string(width) + "x" + std::to_string(height) + " image (mixed resolutions?)");
    views.push_back({int(i), c, std::vector<char>(c.size(), 1)});
  }
  if (views.size() < 4)
    throw InputError("calibrate: " + std::to_string(views.size()) + " views with a board, need at least 4");

  auto report = [&](const char* stage, size_t done, size_t total) {
    if (options.progress) options.progress(stage, int(done), int(total));
  };
  CalibrationResult res;
  res.views.resize(corners_per_view.size());
  for (size_t i = 0; i < corners_per_view.size(); ++i) {
    res.views[i].has_board = !corners_per_view[i].empty();
    res.views[i].corners = int(corners_per_view[i].size());
    res.views[i].why = res.views[i].has_board ? "" : "no board";
  }
  std::vector<char> view_used(views.size(), 1);
  auto used_subset = [&](int skip = -1) {
    Subset s;
    for (size_t i = 0; i < views.size(); ++i)
      if (view_used[i] && int(i) != skip) s.push_back(&views[i]);
    return s;
  };

  // 1. Outlier rejection with one reference model, chosen in the first round and kept:
  //    the requested model (rational / pinhole when it cannot be fitted); else whichever
  //    of Kannala-Brandt (narrow to > 180 deg lenses), Mei (catadioptric) and rational
  //    fits all corners with the lowest RMS (earlier in that list on a tie), pinhole when
  //    none can be fitted. A reference that cannot fit the lens at all (Kannala-Brandt on
  //    a mirror camera) would call good corners outliers and throw whole views away.
  //    The last round's fit is the full fit of section 2 (same views, same inliers). With
  //    Kannala-Brandt as the reference, later rounds (the inlier set changed a little)
  //    re-solve warm from the previous round's fit: no OpenCV seed, no re-posing, the same
  //    minimum (within 1.5e-4 px of cold solves on the three KB real sets). Not for the
  //    other references: Mei's xi/focal valley and the rational model's free extrapolation
  //    make where a solve stops depend on its start, and on Ladybug warm rounds moved Mei
  //    by 0.17 px RMS and rejected other corners; those re-solve from scratch as before.
  std::string ref;
  std::optional<Fit> last;  // ref's fit in the previous round, on last_views
  Subset last_views;
  bool refit_needed = false;  // the inliers changed after `last` was fitted
  // `last` warm-started on the views now used (a subset of last_views).
  auto warm_from_last = [&](const Subset& now) {
    std::vector<Pose> poses;
    for (const View* v : now)
      poses.push_back(last->poses[size_t(std::find(last_views.begin(), last_views.end(), v) - last_views.begin())]);
    return warm_refit(pr, now, ref, *last, poses);
  };
  for (int round = 0; round < std::max(1, options.outlier_rounds); ++round) {
    report("outlier rejection", size_t(round), size_t(std::max(1, options.outlier_rounds)));
    Fitter fitter(pr, used_subset());
    if (last && last->ok && ref == kKB) fitter.adopt(ref, warm_from_last(fitter.views()));
    if (ref.empty()) {
      if (!options.model.empty()) {
        for (const std::string& r : {options.model, std::string(kOpenCV8), std::string(kPinhole)})
          if (fitter.get(r).ok) {
            ref = r;
            break;
          }
      } else {
        Subset sample = fitter.views();
        const size_t cap = size_t(std::max(4, options.reference_views));
        if (sample.size() > cap) {
          Subset spaced;
          for (size_t k = 0; k < cap; ++k) spaced.push_back(sample[k * sample.size() / cap]);
          sample = spaced;
        }
        Fitter sampled(pr, sample);
        Fitter& chooser = sample.size() == fitter.views().size() ? fitter : sampled;
        double best_rms = std::numeric_limits<double>::infinity();
        for (const char* r : {kKB, kMei, kOpenCV8}) {
          const Fit& g = chooser.get(r);
          if (!g.ok) continue;
          const double e = fit_rms(pr, g, sample);
          if (e < best_rms) {
            best_rms = e;
            ref = r;
          }
        }
        if (!ref.empty() && !fitter.get(ref).ok) ref.clear();  // fits the sample, not all views
        if (ref.empty())
          for (const char* r : {kKB, kMei, kOpenCV8, kPinhole})
            if (fitter.get(r).ok) {
              ref = r;
              break;
            }
      }
    }
    if (ref.empty() || !fitter.get(ref).ok) throw InputError("calibrate: no model could be fitted to the corners");
    const Fit* f = &fitter.get(ref);
    res.outlier_rounds = round + 1;
    const Subset& sub = fitter.views();
    std::vector<std::vector<std::array<double, 2>>> rs;
    std::vector<double> comps;
    for (size_t i = 0; i < sub.size(); ++i) {
      rs.push_back(view_residuals(pr, f->model, *sub[i], f->poses[i]));
      for (size_t k = 0; k < rs.back().size(); ++k)
        if (sub[i]->inlier[k] && std::isfinite(rs.back()[k][0])) {
          comps.push_back(std::abs(rs.back()[k][0]));
          comps.push_back(std::abs(rs.back()[k][1]));
        }
    }
    const double sigma = 1.4826 * median_of(comps);
    const double thr = std::max(options.outlier_k * sigma, options.outlier_floor_px);
    // The inlier set is recomputed from every corner each round, so corners that a
    // gross outlier dragged off in the first fit come back once it is gone.
    bool changed = false;
    for (size_t i = 0; i < sub.size(); ++i) {
      View& v = const_cast<View&>(*sub[i]);
      for (size_t k = 0; k < v.px.size(); ++k) {
        const char in = std::hypot(rs[i][k][0], rs[i][k][1]) <= thr;
        if (v.inlier[k] != in) {
          v.inlier[k] = in;
          changed = true;
        }
      }
    }
    for (size_t i = 0; i < views.size(); ++i) {
      if (!view_used[i]) continue;
      const int bad = int(std::count(views[i].inlier.begin(), views[i].inlier.end(), 0));
      if (bad > options.max_view_outlier_fraction * ncorners || ncorners - bad < 4) {
        view_used[i] = 0;
        res.views[views[i].index].why =
            "too many outlier corners (" + std::to_string(bad) + " of " + std::to_string(ncorners) + ")";
        changed = true;
      }
    }
    last = *f;
    last_views = sub;
    refit_needed = changed;
    if (!changed) break;
  }
  const Subset used = used_subset();
  if (used.size() < 4)
    throw InputError("calibrate: only " + std::to_string(used.size()) +
                     " views left after outlier rejection, need at least 4");

  // 2. Candidates: full fit, odd/even halves, cross-validation and held-out error.
  Subset half[2];
  for (size_t i = 0; i < used.size(); ++i) half[i % 2].push_back(used[i]);
  const std::vector<uint8_t> mask = coverage_mask(pr, used);
  const int step = auto_step(pr);
  Fitter full(pr, used), fa(pr, half[0]), fb(pr, half[1]);
  if (last && last->ok) {
    if (!refit_needed)
      full.adopt(ref, std::move(*last));
    else if (ref == kKB)
      full.adopt(ref, warm_from_last(used));
  }
  for (const auto& name : candidates) {
    report("candidates", res.table.size(), candidates.size());
    ModelCandidate c;
    c.name = name;
    const Fit& f = full.get(name);
    if (!f.ok) {
      c.error = f.error;
      res.table.push_back(c);
      continue;
    }
    c.lensmodel = f.model.lensmodel;
    c.params = f.params;
    c.rms_px = fit_rms(pr, f, used);
    c.model = f.model;
    c.model.rms_reprojection_px = c.rms_px;
    const Fit& a = fa.get(name);
    const Fit& b = fb.get(name);
    if (!a.ok || !b.ok) {
      c.error = "a half of the views could not be fitted: " + (a.ok ? b.error : a.error);
      res.table.push_back(c);
      continue;
    }
    const ProjectionDiff d = projection_difference(a.model, b.model, mask, step);
    c.cross_validation_px = d.samples > 0 ? d.rms_px : std::numeric_limits<double>::infinity();
    c.cross_validation_median_px = d.median_px;
    const double h1 = heldout_rms(pr, a.model, half[1]), h2 = heldout_rms(pr, b.model, half[0]);
    c.heldout_rms_px = std::sqrt(0.5 * (h1 * h1 + h2 * h2));
    c.model.cross_validation_px = c.cross_validation_px;
    c.ok = std::isfinite(c.cross_validation_px);
    if (!c.ok) c.error = "no covered pixel both half-models can image";
    res.table.push_back(c);
  }

  // 3. Selection: fewest parameters within the noise of the best cross-validation, ranked
  //    on the cross-validation repeated over options.cv_splits balanced splits (one split
  //    is one noisy draw: it scattered by ~2x between noise draws of one setup).
  const ModelCandidate* best_odd_even = nullptr;
  for (const auto& c : res.table)
    if (c.ok && (!best_odd_even || c.cross_validation_px < best_odd_even->cross_validation_px)) best_odd_even = &c;
  if (!best_odd_even) {
    std::string why;
    for (const auto& c : res.table) why += (why.empty() ? "" : "; ") + c.name + ": " + c.error;
    throw InputError("calibrate: no candidate model could be fitted (" + why + ")");
  }
  // The splits; the first (odd/even) is the table's, fitted cold above. Candidates that
  // cannot matter (odd/even cross-validation hopeless) get no further splits.
  const std::vector<std::vector<int>> splits = balanced_splits(int(used.size()), std::max(1, options.cv_splits));
  bool repeated = false;
  if (splits.size() > 1)
    for (auto& c : res.table) {
      report("repeated splits", size_t(&c - res.table.data()), res.table.size());
      if (!c.ok || c.cross_validation_px > options.fit_max_cross_validation_px ||
          c.cross_validation_px > options.selection_screen_factor * best_odd_even->cross_validation_px +
                                      options.selection_floor_px)
        continue;
      c.cross_validation_splits_px = {c.cross_validation_px};
      for (size_t k = 1; k < splits.size(); ++k) {
        c.cross_validation_splits_px.push_back(
            split_cross_validation(pr, used, splits[k], c.name, full.get(c.name), mask, step));
        if (!std::isfinite(c.cross_validation_splits_px.back())) break;  // cannot qualify: stop paying
      }
      c.cross_validation_repeated_px = rms_over_splits(c.cross_validation_splits_px);
      if (std::isfinite(c.cross_validation_repeated_px)) repeated = true;
    }
  res.selected_on = repeated ? "repeated" : "odd/even";
  res.cv_splits = repeated ? int(splits.size()) : 1;
  const auto score = [&](const ModelCandidate& c) {
    if (!c.ok) return std::numeric_limits<double>::infinity();
    if (!repeated) return c.cross_validation_px;
    return std::isfinite(c.cross_validation_repeated_px) ? c.cross_validation_repeated_px
                                                         : std::numeric_limits<double>::infinity();
  };
  const ModelCandidate* best = repeated ? nullptr : best_odd_even;
  if (repeated)
    for (const auto& c : res.table)
      if (std::isfinite(score(c)) && (!best || score(c) < score(*best))) best = &c;
  if (repeated && best->cross_validation_splits_px.size() >= 2) {
    const auto& v = best->cross_validation_splits_px;
    const double mean = std::accumulate(v.begin(), v.end(), 0.0) / double(v.size());
    double ss = 0;
    for (double x : v) ss += (x - mean) * (x - mean);
    res.cv_split_noise_px = std::sqrt(ss / double(v.size() - 1)) / std::sqrt(double(v.size()));
  }
  // The noise of a cross-validation: a jackknife standard error of the best model's. Each
  // view is left out of its half in turn (that half refitted warm, the other kept); as the
  // two halves are independent samples, Var = sum over halves of (m_h - 1) * s_h^2 (the
  // two-sample jackknife), with s_h a robust spread (1.4826 MAD) of that half's values so
  // that one influential view does not make every model "within noise". Only the
  // selection uses it: skipped (NaN) when the model is forced.
  res.cv_noise_px = std::numeric_limits<double>::quiet_NaN();
  if (options.model.empty()) {
    Fitter* halves[2] = {&fa, &fb};
    std::vector<double> cvs[2];
    for (size_t i = 0; i < used.size(); ++i) {
      report("noise jackknife", i, used.size());
      const int h = int(i % 2), pos = int(i / 2);
      Subset rest;
      for (size_t j = 0; j < half[h].size(); ++j)
        if (int(j) != pos) rest.push_back(half[h][j]);
      const Fit& from = halves[h]->get(best->name);
      std::vector<Pose> poses;
      for (size_t j = 0; j < from.poses.size(); ++j)
        if (int(j) != pos) poses.push_back(from.poses[j]);
      const Fit refit = warm_refit(pr, rest, best->name, from, poses);
      if (!refit.ok) continue;
      const ProjectionDiff d = projection_difference(refit.model, halves[1 - h]->get(best->name).model, mask, step);
      if (d.samples > 0) cvs[h].push_back(d.rms_px);
    }
    res.cv_noise_px = std::numeric_limits<double>::quiet_NaN();
    if (cvs[0].size() >= 3 && cvs[1].size() >= 3) {
      double var = 0;
      for (const auto& v : cvs) {
        const double med = median_of(v);
        std::vector<double> dev;
        for (double c : v) dev.push_back(std::abs(c - med));
        const double sh = 1.4826 * median_of(dev);
        var += double(v.size() - 1) * sh * sh;
      }
      res.cv_noise_px = std::sqrt(var);
    }
  }
  // The tolerance. The K-split mean scatters less than one split, by up to sqrt(K) (less:
  // the splits share the views, and the data's own noise is common to all of them), so the
  // odd/even jackknife SE is a conservative bound on its noise; the per-split spread /
  // sqrt(K) measures only the split-to-split part, from K values. docs/calibration.md
  // ("Model selection uses the measured noise") has the measurement that chose the default.
  const double noise_used = options.selection_noise_from_splits && std::isfinite(res.cv_split_noise_px)
                                ? res.cv_split_noise_px
                                : res.cv_noise_px;
  const double noise = std::isfinite(noise_used) ? noise_used : 0.0;
  res.selection_noise_px = noise;
  res.selection_k = options.selection_k;
  res.selection_noise_from_splits = options.selection_noise_from_splits && std::isfinite(res.cv_split_noise_px);
  // The held-out RMS (each half's model on the other half's corners, poses re-solved) is a
  // far more precise statistic than a cross-validation (a mean over every corner, relative
  // standard error ~1 / sqrt(2 n) over n residual components, and the same corners for every
  // candidate): a model whose held-out error is significantly above the best's misses the
  // corners, however noisy the cross-validation (with few views, its spread is wide). Not
  // the full fit's RMS: it falls with every parameter added, so once the best could be the
  // 100-parameter spline (ranked on 4 splits, Ladybug: RMS 0.182 against Kannala-Brandt's
  // 0.224, held-out 0.232 against 0.228) it disqualified every parametric model.
  int components = 0;
  for (const View* v : used) components += 2 * int(std::count(v->inlier.begin(), v->inlier.end(), 1));
  const double heldout_limit =
      best->heldout_rms_px * (1 + options.selection_k / std::sqrt(double(std::max(1, components))));
  const ModelCandidate* pick = best;
  for (auto& c : res.table)
    c.within_noise = c.ok && c.cross_validation_px <= options.fit_max_cross_validation_px &&
                     score(c) <= options.fit_max_cross_validation_px &&
                     score(c) - score(*best) <= options.selection_k * noise + options.selection_floor_px &&
                     c.heldout_rms_px <= heldout_limit;
  for (const auto& c : res.table)
    if (c.ok && c.within_noise && (c.params < pick->params || (c.params == pick->params && score(c) < score(*pick))))
      pick = &c;
  res.selected = pick->name;
  res.no_model_fits = true;
  for (const auto& c : res.table)
    if (c.ok && c.rms_px <= options.fit_max_rms_px && c.cross_validation_px <= options.fit_max_cross_validation_px)
      res.no_model_fits = false;
  res.model = pick->model;
  res.cross_validation_px = pick->cross_validation_px;
  res.cross_validation_repeated_px = pick->cross_validation_repeated_px;
  res.cross_validation_median_px = pick->cross_validation_median_px;
  res.heldout_rms_px = pick->heldout_rms_px;
  const Fit& chosen = full.get(pick->name);

  // 4. Residuals, per-view RMS, coverage, edge bands.
  res.view_rms_px.assign(corners_per_view.size(), 0.0);
  res.coverage_nx = std::max(1, options.coverage_nx);
  res.coverage_ny = std::max(1, options.coverage_ny);
  res.coverage.assign(size_t(res.coverage_nx) * res.coverage_ny, 0);
  size_t ui = 0;
  for (size_t i = 0; i < views.size(); ++i) {
    const View& v = views[i];
    Pose pose;
    if (view_used[i]) {
      pose = chosen.poses[ui++];
    } else {
      const auto p = solve_pose(pr, res.model, v);
      if (!p) continue;
      pose = *p;
    }
    const auto r = view_residuals(pr, res.model, v, pose);
    std::vector<double> sq;
    int rejected = 0;
    for (size_t k = 0; k < r.size(); ++k) {
      res.residuals.push_back({v.index, int(k), r[k][0], r[k][1], !v.inlier[k]});
      res.corners_total++;
      if (!v.inlier[k]) {
        rejected++;
        continue;
      }
      sq.push_back(r[k][0] * r[k][0] + r[k][1] * r[k][1]);
      if (!view_used[i]) continue;
      const double x = v.px[k][0], y = v.px[k][1];
      const int cx = std::clamp(int((x + 0.5) / width * res.coverage_nx), 0, res.coverage_nx - 1);
      const int cy = std::clamp(int((y + 0.5) / height * res.coverage_ny), 0, res.coverage_ny - 1);
      res.coverage[size_t(cy) * res.coverage_nx + cx]++;
      const double bx = options.edge_band * width, by = options.edge_band * height;
      if (x < bx) res.edge_observations[0]++;
      if (x > width - bx) res.edge_observations[1]++;
      if (y < by) res.edge_observations[2]++;
      if (y > height - by) res.edge_observations[3]++;
    }
    res.corners_rejected += rejected;
    ViewReport& vr = res.views[v.index];
    vr.rejected_corners = rejected;
    vr.used = view_used[i];
    vr.rms_px = rms_of(sq);
    res.view_rms_px[v.index] = vr.rms_px;
  }
  for (int e : res.edge_observations)
    if (e < options.min_edge_observations) res.corners_poorly_covered = true;

  // 5. Jackknife leverage of each used view for the chosen model.
  std::vector<CameraModel> leave_one_out;
  if (options.leverage) {
    std::vector<double> lev;
    std::vector<int> idx;
    for (size_t i = 0; i < views.size(); ++i) {
      report("leverage", i, views.size());
      if (!view_used[i]) continue;
      const Subset loo = used_subset(int(i));
      std::vector<Pose> poses;
      for (size_t j = 0, u = 0; j < views.size(); ++j) {
        if (!view_used[j]) continue;
        if (j != i) poses.push_back(chosen.poses[u]);
        ++u;
      }
      const Fit f = warm_refit(pr, loo, pick->name, chosen, poses);
      double l = std::numeric_limits<double>::infinity();
      if (f.ok) {
        const ProjectionDiff d = projection_difference(f.model, res.model, mask, step);
        if (d.samples > 0) l = d.rms_px;
        leave_one_out.push_back(f.model);
      }
      res.views[views[i].index].leverage_px = l;
      lev.push_back(l);
      idx.push_back(views[i].index);
    }
    const double med = median_of(lev);
    for (size_t j = 0; j < lev.size(); ++j)
      res.views[idx[j]].influential = lev[j] > options.leverage_flag_factor * med && lev[j] > options.leverage_min_px;
  }
  res.model.rms_reprojection_px = pick->rms_px;
  res.model.cross_validation_px = pick->cross_validation_px;

  // 6. Projection uncertainty of the chosen model: linear (full fit over the image; each
  //    half's own for the cross-validation forecast) and jackknife.
  if (options.uncertainty) {
    UncertaintyReport& u = res.uncertainty;
    const auto grid = grid_pixels(res.model, std::max(1, options.uncertainty_nx), std::max(1, options.uncertainty_ny));
    const auto cv_pixels = mask_pixels(mask, width, height, step);
    const auto solved = [&](const Subset& s, const Fit& f) {
      std::vector<SolvedView> out;
      for (size_t i = 0; i < s.size(); ++i) out.push_back({f.poses[i], s[i]->px, s[i]->inlier});
      return out;
    };
    const auto sv = solved(used, chosen);
    const LinearCovariance cov = linearised_covariance(chosen.model, board, sv);
    u.linear_ok = cov.ok;
    u.linear_error = cov.error;
    u.sigma_px = cov.sigma_px;
    const int gx = std::max(1, options.uncertainty_nx), gy = std::max(1, options.uncertainty_ny);
    u.mean_frames = linear_uncertainty_mean_frames(cov, chosen.model, sv, grid, gx, gy);
    u.rotation_fitted = linear_uncertainty_rotation_fitted(cov, chosen.model, mask, step, grid, gx, gy);
    u.predicted_cv_linear_px = std::numeric_limits<double>::quiet_NaN();
    const Fit& a = fa.get(pick->name);
    const Fit& b = fb.get(pick->name);
    if (cov.ok && a.ok && b.ok) {
      const LinearCovariance ca = linearised_covariance(a.model, board, solved(half[0], a));
      const LinearCovariance cb = linearised_covariance(b.model, board, solved(half[1], b));
      if (ca.ok && cb.ok) {
        const int n = int(cv_pixels.size());
        const double ra = rms_over(linear_uncertainty_rotation_fitted(ca, a.model, mask, step, cv_pixels, n, 1));
        const double rb = rms_over(linear_uncertainty_rotation_fitted(cb, b.model, mask, step, cv_pixels, n, 1));
        u.predicted_cv_linear_px = std::sqrt(ra * ra + rb * rb);
      }
    }
    u.predicted_cv_jackknife_px = std::numeric_limits<double>::quiet_NaN();
    if (leave_one_out.size() >= 3) {
      u.jackknife = jackknife_uncertainty(res.model, leave_one_out, cv_pixels, grid, gx, gy);
      const int n = int(cv_pixels.size());
      u.predicted_cv_jackknife_px =
          2 * rms_over(jackknife_uncertainty(res.model, leave_one_out, cv_pixels, cv_pixels, n, 1));
    }
    u.headline = leave_one_out.size() >= 3 ? "jackknife" : "linear";
    // Every candidate's own linear uncertainty over the covered area (the issue compares
    // candidates by cross-validation and by projection uncertainty side by side). Sampled
    // more coarsely than the cross-validation: a summary, not a map.
    {
      std::vector<std::array<double, 2>> coarse;
      const size_t stride = std::max<size_t>(1, cv_pixels.size() / 400);
      for (size_t k = 0; k < cv_pixels.size(); k += stride) coarse.push_back(cv_pixels[k]);
      for (ModelCandidate& c : res.table) {
        report("uncertainty", size_t(&c - res.table.data()), res.table.size());
        if (!c.ok) continue;
        const Fit& f = full.get(c.name);
        if (!f.ok) continue;
        const LinearCovariance cc = linearised_covariance(f.model, board, solved(used, f));
        if (!cc.ok) continue;
        const double s = rms_over(
            linear_uncertainty_rotation_fitted(cc, f.model, mask, step, coarse, int(coarse.size()), 1));
        c.linear_sigma_px = s;
        c.linear_forecast_cv_px = 2 * s;
      }
    }
    // The cross-validation repeated over balanced splits (the selection's, when it ranked
    // on them; else over four: odd/even and three pseudo-random).
    {
      std::vector<double> v = pick->cross_validation_splits_px;
      if (v.size() < 2) {
        const auto sp = splits.size() > 1 ? splits : balanced_splits(int(used.size()), 4);
        v = {pick->cross_validation_px};
        for (size_t k = 1; k < sp.size(); ++k) v.push_back(split_cross_validation(pr, used, sp[k], pick->name, chosen, mask, step));
      }
      std::vector<double> finite;
      for (double x : v)
        if (std::isfinite(x)) finite.push_back(x);
      u.cv_splits = int(finite.size());
      u.cv_repeated_px = finite.empty() ? std::numeric_limits<double>::quiet_NaN() : rms_over_splits(finite);
    }
  }
  report("done", 1, 1);
  return res;
}

}  // namespace lp

namespace lp {

namespace {

// The views that have a board, every corner an inlier (the peers' and one-solve paths use
// every corner); `who` names the caller in the errors.
std::vector<View> views_with_all_corners(const std::vector<std::vector<std::array<double, 2>>>& corners_per_view,
                                         const BoardSpec& board, const std::string& who) {
  std::vector<View> views;
  for (size_t i = 0; i < corners_per_view.size(); ++i)
    if (!corners_per_view[i].empty()) {
      if (int(corners_per_view[i].size()) != board.cols * board.rows)
        throw InputError(who + ": view " + std::to_string(i) + " has the wrong number of corners");
      views.push_back({int(i), corners_per_view[i], std::vector<char>(corners_per_view[i].size(), 1)});
    }
  if (views.size() < 4) throw InputError(who + ": need at least 4 views with a board");
  return views;
}

}  // namespace

SingleSolve solve_model_once(const std::vector<std::vector<std::array<double, 2>>>& corners_per_view,
                             const BoardSpec& board, int width, int height, const std::string& model,
                             const CalibrateOptions& options) {
  if (std::find(all_candidates().begin(), all_candidates().end(), model) == all_candidates().end())
    throw InputError("solve_model_once: unknown model '" + model + "'");
  Problem pr{board, width, height, options};
  const std::vector<View> views = views_with_all_corners(corners_per_view, board, "solve_model_once");
  Subset all;
  for (const View& v : views) all.push_back(&v);
  SingleSolve out;
  const auto t0 = std::chrono::steady_clock::now();
  Fitter fitter(pr, all);
  const Fit& f = fitter.get(model);
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  out.ok = f.ok;
  out.error = f.error;
  if (!f.ok) return out;
  out.model = f.model;
  out.rms_px = fit_rms(pr, f, all);
  return out;
}

std::vector<PeerCalibration> calibrate_opencv_alone(const std::vector<std::vector<std::array<double, 2>>>& corners_per_view,
                                                    const BoardSpec& board, int width, int height, int diff_step_px) {
  CalibrateOptions o;
  o.diff_step_px = diff_step_px;
  Problem pr{board, width, height, o};
  const std::vector<View> views = views_with_all_corners(corners_per_view, board, "calibrate_opencv_alone");
  Subset all, half[2];
  for (size_t i = 0; i < views.size(); ++i) {
    all.push_back(&views[i]);
    half[i % 2].push_back(&views[i]);
  }
  const std::vector<uint8_t> mask = coverage_mask(pr, all);
  const int step = auto_step(pr);
  auto fit = [&](const std::string& name, const Subset& s, std::vector<char>& posed) -> Fit {
    posed.assign(s.size(), 1);
    if (name == "cv::fisheye") return fit_opencv_kb(pr, s, [](const std::array<double, 2>&) { return true; }, &posed);
    if (name == "cv::omnidir") return fit_opencv_omnidir(pr, s, &posed);
    if (name == "cv::calibrateCamera plumb_bob") return fit_opencv_pinhole_family(pr, s, 0, "LENSMODEL_OPENCV5", 5);
    return fit_opencv_pinhole_family(pr, s, cv::CALIB_RATIONAL_MODEL, kOpenCV8, 8);
  };
  std::vector<PeerCalibration> out;
  for (const std::string name :
       {"cv::fisheye", "cv::calibrateCamera plumb_bob", "cv::calibrateCamera rational", "cv::omnidir"}) {
    PeerCalibration p;
    p.name = name;
    std::vector<char> posed;
    const auto t0 = std::chrono::steady_clock::now();
    const Fit f = fit(name, all, posed);
    p.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!f.ok) {
      p.error = f.error;
      out.push_back(p);
      continue;
    }
    p.lensmodel = f.model.lensmodel;
    p.model = f.model;
    Subset posed_views;
    Fit fp = f;
    fp.poses.clear();
    for (size_t i = 0; i < all.size(); ++i)
      if (posed[i]) {
        posed_views.push_back(all[i]);
        fp.poses.push_back(f.poses[i]);
      }
    p.views_posed = int(posed_views.size());
    p.rms_px = fit_rms(pr, fp, posed_views);
    std::vector<char> pa, pb;
    const Fit a = fit(name, half[0], pa), b = fit(name, half[1], pb);
    if (!a.ok || !b.ok) {
      p.error = "a half of the views could not be fitted: " + (a.ok ? b.error : a.error);
      p.cross_validation_px = std::numeric_limits<double>::infinity();
      out.push_back(p);
      continue;
    }
    const ProjectionDiff d = projection_difference(a.model, b.model, mask, step);
    p.cross_validation_px = d.samples > 0 ? d.rms_px : std::numeric_limits<double>::infinity();
    p.ok = std::isfinite(p.rms_px) && p.rms_px < 1e5 && std::isfinite(p.cross_validation_px);
    if (!p.ok && p.error.empty()) p.error = "cannot image some corners or no covered pixel";
    out.push_back(p);
  }
  return out;
}

}  // namespace lp
