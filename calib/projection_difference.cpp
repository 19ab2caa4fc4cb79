#include "calib/projection_difference.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "calib/calibration_problem.h"

namespace lp {

GridRays grid_rays(const CameraModel& b, const std::vector<uint8_t>& mask, int step_px) {
  GridRays g;
  const int w = b.width, h = b.height, step = std::max(1, step_px);
  for (int y = step / 2; y < h; y += step)
    for (int x = step / 2; x < w; x += step) {
      if (!mask.empty() && !mask[size_t(y) * w + x]) continue;
      const Pixel q{double(x), double(y)};
      g.pixels.push_back(q);
      g.rays.push_back(unproject(b, q));
    }
  return g;
}

ProjectionDiff projection_difference(const CameraModel& a, const CameraModel& b, const std::vector<uint8_t>& mask,
                                     int step_px, bool fit_rotation) {
  return projection_difference(a, b, grid_rays(b, mask, step_px), fit_rotation);
}

namespace {

// a_ray(i, q): a's ray at b_rays' i-th grid pixel q.
template <class ARay>
ProjectionDiff difference_of_rays(const ARay& a_ray, const CameraModel& b, const GridRays& b_rays, bool fit_rotation) {
  ProjectionDiff out;
  std::vector<Vec3> va, vb;
  std::vector<Pixel> qs;
  for (size_t i = 0; i < b_rays.pixels.size(); ++i) {
    const auto& db = b_rays.rays[i];
    if (!db) continue;
    const Pixel q = b_rays.pixels[i];
    const std::optional<Vec3> da = a_ray(i, q);
    if (!da) continue;
    va.push_back(*da);
    vb.push_back(*db);
    qs.push_back(q);
  }
  // The rotation that best aligns a's rays with b's (Kabsch).
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

}  // namespace

ProjectionDiff projection_difference(const CameraModel& a, const CameraModel& b, const GridRays& b_rays,
                                     bool fit_rotation) {
  return difference_of_rays([&](size_t, const Pixel& q) { return unproject(a, q); }, b, b_rays, fit_rotation);
}

ProjectionDiff projection_difference(const GridRays& a_rays, const CameraModel& b, const GridRays& b_rays,
                                     bool fit_rotation) {
  if (a_rays.pixels.size() != b_rays.pixels.size())
    throw std::invalid_argument("projection_difference: the two models' rays are on different grids");
  return difference_of_rays([&](size_t i, const Pixel&) { return a_rays.rays[i]; }, b, b_rays, fit_rotation);
}

}  // namespace lp
