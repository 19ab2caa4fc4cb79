#include "core/vec3.h"

#include <algorithm>
#include <cmath>

namespace lp {

Mat3 operator*(const Mat3& a, const Mat3& b) {
  Mat3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[3 * i + j] = a(i, 0) * b(0, j) + a(i, 1) * b(1, j) + a(i, 2) * b(2, j);
  return r;
}

Mat3 rotation_from_yaw_pitch_roll_deg(double yaw, double pitch, double roll) {
  const double d2r = M_PI / 180.0;
  const double cy = std::cos(yaw * d2r), sy = std::sin(yaw * d2r);
  const double cp = std::cos(pitch * d2r), sp = std::sin(pitch * d2r);
  const double cr = std::cos(roll * d2r), sr = std::sin(roll * d2r);
  const Mat3 rz{{cy, -sy, 0, sy, cy, 0, 0, 0, 1}};
  const Mat3 ry{{cp, 0, sp, 0, 1, 0, -sp, 0, cp}};
  const Mat3 rx{{1, 0, 0, 0, cr, -sr, 0, sr, cr}};
  return rz * (ry * rx);
}

// Newton's iteration for the polar factor, R <- (R + R^-T) / 2: quadratic near a rotation,
// so a matrix within 1e-4 of one is orthonormal to rounding in three or four steps.
Mat3 nearest_rotation(const Mat3& a) {
  Mat3 r = a;
  for (int it = 0; it < 30; ++it) {
    Mat3 cof;  // cofactors: R^-T = cof / det
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        const int i1 = (i + 1) % 3, i2 = (i + 2) % 3, j1 = (j + 1) % 3, j2 = (j + 2) % 3;
        cof.m[size_t(3 * i + j)] = r(i1, j1) * r(i2, j2) - r(i1, j2) * r(i2, j1);
      }
    const double det = r(0, 0) * cof(0, 0) + r(0, 1) * cof(0, 1) + r(0, 2) * cof(0, 2);
    double change = 0;
    Mat3 next;
    for (size_t k = 0; k < 9; ++k) {
      next.m[k] = 0.5 * (r.m[k] + cof.m[k] / det);
      change = std::max(change, std::fabs(next.m[k] - r.m[k]));
    }
    r = next;
    if (!(change > 1e-15)) break;
  }
  return r;
}

std::array<double, 3> yaw_pitch_roll_deg(const Mat3& r) {
  const double r2d = 180.0 / M_PI;
  // R = Rz(yaw) Ry(pitch) Rx(roll): R20 = -sin(pitch), R21 / R22 = tan(roll), R10 / R00 = tan(yaw).
  const double pitch = std::asin(std::clamp(-r(2, 0), -1.0, 1.0));
  if (std::hypot(r(2, 1), r(2, 2)) < 1e-12)  // gimbal lock: roll 0, R01 = -sin(yaw), R11 = cos(yaw)
    return {std::atan2(-r(0, 1), r(1, 1)) * r2d, pitch * r2d, 0.0};
  return {std::atan2(r(1, 0), r(0, 0)) * r2d, pitch * r2d, std::atan2(r(2, 1), r(2, 2)) * r2d};
}

bool is_rotation(const Mat3& a, double tol) {
  const Mat3 p = transpose(a) * a;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (std::fabs(p(i, j) - (i == j ? 1.0 : 0.0)) > tol) return false;
  const double det = a(0, 0) * (a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1)) -
                     a(0, 1) * (a(1, 0) * a(2, 2) - a(1, 2) * a(2, 0)) +
                     a(0, 2) * (a(1, 0) * a(2, 1) - a(1, 1) * a(2, 0));
  return std::fabs(det - 1.0) < tol;
}

}  // namespace lp
