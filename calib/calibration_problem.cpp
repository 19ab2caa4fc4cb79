#include "calib/calibration_problem.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace lp {

void report_progress(const StageProgress& progress, const char* stage, size_t done, size_t total) {
  if (progress) progress(stage, int(done), int(total));
}

std::vector<BoardView> make_board_views(const std::vector<std::vector<std::array<double, 2>>>& corners_per_view,
                                        const CalibrationProblem& pr, const std::string& who, bool check_inside) {
  const int ncorners = pr.board.cols * pr.board.rows;
  std::vector<BoardView> views;
  for (size_t i = 0; i < corners_per_view.size(); ++i) {
    const auto& c = corners_per_view[i];
    if (c.empty()) continue;
    if (int(c.size()) != ncorners)
      throw InputError(who + ": view " + std::to_string(i) + " has " + std::to_string(c.size()) +
                       " corners, the board has " + std::to_string(ncorners));
    if (check_inside)
      for (const auto& p : c)
        if (!(p[0] >= -0.5 && p[0] <= pr.width - 0.5 && p[1] >= -0.5 && p[1] <= pr.height - 0.5))
          throw InputError(who + ": view " + std::to_string(i) + " has a corner outside the " +
                           std::to_string(pr.width) + "x" + std::to_string(pr.height) + " image (mixed resolutions?)");
    views.push_back({int(i), c, std::vector<char>(c.size(), 1)});
  }
  if (views.size() < 4)
    throw InputError(who + ": " + std::to_string(views.size()) + " views with a board, need at least 4");
  return views;
}

ViewSubset all_of(const std::vector<BoardView>& views) {
  ViewSubset s;
  for (const BoardView& v : views) s.push_back(&v);
  return s;
}

ViewSubset evenly_spaced(const ViewSubset& views, size_t count) {
  if (views.size() <= count) return views;
  ViewSubset spaced;
  for (size_t k = 0; k < count; ++k) spaced.push_back(views[k * views.size() / count]);
  return spaced;
}

std::array<double, 3> board_point(const BoardSpec& b, int k, const BoardWarp& warp) {
  return {(k % b.cols) * b.square_mm, (k / b.cols) * b.square_mm, board_warp_z(b, k, warp)};
}

CameraModel make_model(const CalibrationProblem& pr, const std::string& lensmodel, std::vector<double> intrinsics) {
  CameraModel m;
  m.lensmodel = lensmodel;
  m.intrinsics = std::move(intrinsics);
  m.width = pr.width;
  m.height = pr.height;
  return m;
}

namespace {

// Camera-frame points of a view's board corners.
std::vector<Vec3> board_in_camera(const CalibrationProblem& pr, const BoardWarp& warp, const BoardPose& p) {
  cv::Matx33d R;
  cv::Rodrigues(cv::Vec3d(p[0], p[1], p[2]), R);
  const int n = pr.board.cols * pr.board.rows;
  std::vector<Vec3> out(n);
  for (int k = 0; k < n; ++k) {
    const auto b = board_point(pr.board, k, warp);
    const cv::Vec3d X = R * cv::Vec3d(b[0], b[1], b[2]) + cv::Vec3d(p[3], p[4], p[5]);
    out[k] = {X[0], X[1], X[2]};
  }
  return out;
}

// Within this of a pose already refined (rotation vector in rad, translation relative to its
// length), a refinement is in that pose's basin: distinct minima of a board's pose (the planar
// flip) lie degrees apart.
constexpr double kSamePoseTolerance = 1e-3;
bool same_pose(const BoardPose& a, const BoardPose& b) {
  const double dr = std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
  const double dt = std::hypot(a[3] - b[3], a[4] - b[4], a[5] - b[5]);
  return dr < kSamePoseTolerance && dt < kSamePoseTolerance * std::hypot(b[3], b[4], b[5]);
}

// Pixel residuals of a pose (Levenberg-Marquardt with numeric derivatives). nullopt when it
// reaches one of `found` (refined already): it would end there.
std::optional<BoardPose> refine_pose(const CalibrationProblem& pr, const CameraModel& m, const BoardWarp& warp,
                                     const BoardView& v, BoardPose p, const std::vector<BoardPose>& found = {}) {
  auto resid = [&](const BoardPose& q, Eigen::VectorXd& r) {
    const auto rr = view_residuals(pr, m, warp, v, q);
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
      BoardPose q = p;
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
      BoardPose q = p;
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
        for (const BoardPose& f : found)
          if (same_pose(p, f)) return std::nullopt;
      } else {
        lambda *= 10;
      }
    }
    if (!improved) break;
  }
  return p;
}

// PnP starts on normalised rays in the frame R0 (camera -> PnP frame) turns the camera into;
// rays less than ~84 deg from that frame's axis only. Each of IPPE's two solutions that is
// not the same pose: a small, distant board seen nearly face on has two poses that image it
// almost alike (the planar flip), and a start in the wrong one stays there under refinement.
// IPPE's second solution is kept only when its residual is within kFlipResidualRatio of the
// first's; otherwise the view is unambiguous. OpenCV's iterative PnP only where IPPE gives
// none: beside IPPE it was a third start that refined to IPPE's first (its own
// Levenberg-Marquardt, 40 % of solve_pose's time on 16 views of a 190 deg lens).
std::vector<BoardPose> pnp_starts_on_rays(const std::vector<cv::Point3d>& obj, const std::vector<cv::Vec3d>& rays,
                                          const cv::Matx33d& R0) {
  constexpr double kFlipResidualRatio = 10;
  std::vector<cv::Point3d> o;
  std::vector<cv::Point2d> q;
  for (size_t k = 0; k < rays.size(); ++k) {
    const cv::Vec3d d = R0 * rays[k];
    if (d[2] < 0.1) continue;
    o.push_back(obj[k]);
    q.push_back({d[0] / d[2], d[1] / d[2]});
  }
  std::vector<BoardPose> starts;
  if (o.size() < 6) return starts;
  auto keep = [&](const cv::Vec3d& rv, const cv::Vec3d& tv) {
    cv::Matx33d R;
    cv::Rodrigues(rv, R);
    const cv::Matx33d Rc = R0.t() * R;
    const cv::Vec3d tc = R0.t() * tv;
    for (const BoardPose& s : starts) {  // the same pose as one kept: within ~1 deg
      cv::Matx33d Rs;
      cv::Rodrigues(cv::Vec3d(s[0], s[1], s[2]), Rs);
      if (cv::norm(cv::Mat(Rs.t() * Rc - cv::Matx33d::eye())) < 0.02) return;
    }
    cv::Vec3d rc;
    cv::Rodrigues(Rc, rc);
    starts.push_back(BoardPose{rc[0], rc[1], rc[2], tc[0], tc[1], tc[2]});
  };
  try {
    std::vector<cv::Mat> rvs, tvs;
    cv::Mat err;
    cv::solvePnPGeneric(o, q, cv::Matx33d::eye(), cv::noArray(), rvs, tvs, false, cv::SOLVEPNP_IPPE, cv::noArray(),
                        cv::noArray(), err);
    for (size_t i = 0; i < rvs.size(); ++i) {
      if (i > 0 && !(err.at<double>(int(i)) <= kFlipResidualRatio * err.at<double>(0))) break;
      keep(cv::Vec3d(rvs[i]), cv::Vec3d(tvs[i]));
    }
  } catch (const cv::Exception&) {  // not coplanar enough for IPPE (a warped board): the iterative start
  }
  if (!starts.empty()) return starts;
  try {
    cv::Vec3d rv, tv;
    if (cv::solvePnP(o, q, cv::Matx33d::eye(), cv::noArray(), rv, tv, false, cv::SOLVEPNP_ITERATIVE)) keep(rv, tv);
  } catch (const cv::Exception&) {
  }
  return starts;
}

}  // namespace

std::vector<std::array<double, 2>> view_residuals(const CalibrationProblem& pr, const CameraModel& m,
                                                  const BoardWarp& warp, const BoardView& v, const BoardPose& pose) {
  const auto P = board_in_camera(pr, warp, pose);
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

double view_squared_error(const CalibrationProblem& pr, const CameraModel& m, const BoardWarp& warp,
                          const BoardView& v, const BoardPose& pose) {
  const auto r = view_residuals(pr, m, warp, v, pose);
  double s = 0;
  for (size_t k = 0; k < r.size(); ++k)
    if (v.inlier[k]) s += std::isfinite(r[k][0]) ? r[k][0] * r[k][0] + r[k][1] * r[k][1] : 1e12;
  return s;
}

double rms_of(const std::vector<double>& sq) {
  if (sq.empty()) return 0;
  return std::sqrt(std::accumulate(sq.begin(), sq.end(), 0.0) / double(sq.size()));
}

double corner_field_deg(const CameraModel& model, const ViewSubset& views) {
  double field = 0;
  for (const BoardView* v : views)
    for (size_t k = 0; k < v->px.size(); ++k)
      if (v->inlier[k])
        if (const auto ray = unproject(model, Pixel{v->px[k][0], v->px[k][1]}))
          field = std::max(field, std::acos(std::clamp(ray->z / length(*ray), -1.0, 1.0)) * 180 / M_PI);
  return field;
}

std::vector<double> posed_corner_angles(const CalibrationProblem& pr, const ViewSubset& views, const ModelFit& fit) {
  std::vector<double> angles;
  for (size_t i = 0; i < views.size() && i < fit.poses.size(); ++i) {
    const BoardPose& p = fit.poses[i];
    cv::Matx33d R;
    cv::Rodrigues(cv::Vec3d(p[0], p[1], p[2]), R);
    const cv::Vec3d t(p[3], p[4], p[5]);
    const BoardView& v = *views[i];
    for (size_t k = 0; k < v.px.size(); ++k)
      if (v.inlier[k]) {
        const auto b = board_point(pr.board, int(k), fit.warp);
        const cv::Vec3d c = R * cv::Vec3d(b[0], b[1], b[2]) + t;
        angles.push_back(std::atan2(std::hypot(c[0], c[1]), c[2]));
      }
  }
  return angles;
}

double fit_rms(const CalibrationProblem& pr, const ModelFit& f, const ViewSubset& views) {
  std::vector<double> sq;
  for (size_t i = 0; i < views.size(); ++i) {
    const auto r = view_residuals(pr, f.model, f.warp, *views[i], f.poses[i]);
    for (size_t k = 0; k < r.size(); ++k)
      if (views[i]->inlier[k]) {
        const double e = r[k][0] * r[k][0] + r[k][1] * r[k][1];
        sq.push_back(std::isfinite(e) ? e : 1e12);
      }
  }
  return rms_of(sq);
}

std::optional<BoardPose> solve_pose(const CalibrationProblem& pr, const CameraModel& m, const BoardWarp& warp,
                                    const BoardView& v) {
  std::vector<cv::Point3d> obj;
  std::vector<cv::Vec3d> rays;
  int inliers = 0;
  for (size_t k = 0; k < v.px.size(); ++k) {
    if (!v.inlier[k]) continue;
    ++inliers;
    const auto d = unproject(m, {v.px[k][0], v.px[k][1]});
    if (!d) continue;
    const auto b = board_point(pr.board, int(k), warp);
    obj.push_back({b[0], b[1], b[2]});
    rays.push_back({d->x, d->y, d->z});
  }
  std::vector<BoardPose> starts;
  bool all_front = int(rays.size()) == inliers;
  for (const auto& d : rays) all_front = all_front && d[2] >= 0.1;
  if (all_front) {
    starts = pnp_starts_on_rays(obj, rays, cv::Matx33d::eye());
  } else {
    // Catadioptric and > 180 deg lenses (boards beside or behind the camera): the PnP runs
    // in a frame turned so that the mean ray of the view is its axis.
    cv::Vec3d mean(0, 0, 0);
    for (const auto& d : rays) mean += d;
    if (cv::norm(mean) < 1e-9) return std::nullopt;
    const cv::Vec3d z = mean / cv::norm(mean);
    // Rotation taking z to (0, 0, 1): rows are an orthonormal frame with z last.
    const cv::Vec3d a = std::abs(z[0]) < 0.9 ? cv::Vec3d(1, 0, 0) : cv::Vec3d(0, 1, 0);
    const cv::Vec3d x = cv::normalize(a.cross(z)), y = z.cross(x);
    const cv::Matx33d R0(x[0], x[1], x[2], y[0], y[1], y[2], z[0], z[1], z[2]);
    starts = pnp_starts_on_rays(obj, rays, R0);
  }
  std::optional<BoardPose> best;
  double best_error = std::numeric_limits<double>::infinity();
  std::vector<BoardPose> found;
  for (const BoardPose& s : starts) {
    const std::optional<BoardPose> refined = refine_pose(pr, m, warp, v, s, found);
    if (!refined) continue;
    const BoardPose& p = *refined;
    found.push_back(p);
    const double e = view_squared_error(pr, m, warp, v, p);
    if (!best || e < best_error) {
      best = p;
      best_error = e;
    }
  }
  return best;
}

double heldout_rms(const CalibrationProblem& pr, const ModelFit& f, const ViewSubset& views) {
  std::vector<double> sq;
  for (const BoardView* v : views) {
    const auto pose = solve_pose(pr, f.model, f.warp, *v);
    if (!pose) return std::numeric_limits<double>::infinity();
    const auto r = view_residuals(pr, f.model, f.warp, *v, *pose);
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

std::vector<uint8_t> coverage_mask(const CalibrationProblem& pr, const ViewSubset& views) {
  cv::Mat mask = cv::Mat::zeros(pr.height, pr.width, CV_8U);
  for (const BoardView* v : views) {
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

int auto_step(const CalibrationProblem& pr) {
  if (pr.diff_step_px > 0) return pr.diff_step_px;
  return std::max(2, int(std::lround(std::sqrt(double(pr.width) * pr.height / 5000.0))));
}

}  // namespace lp
