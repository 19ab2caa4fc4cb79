// Small 3-vectors and 3x3 rotations in the world frame of CONVENTIONS.md:
// right-handed, +Z up, azimuth phi from +X towards +Y, zenith theta from +Z.
#pragma once

#include <array>
#include <cmath>

namespace lp {

struct Vec3 {
  double x = 0, y = 0, z = 0;
};

inline Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3 operator-(Vec3 a) { return {-a.x, -a.y, -a.z}; }
inline Vec3 operator*(double s, Vec3 a) { return {s * a.x, s * a.y, s * a.z}; }
inline Vec3 operator*(Vec3 a, double s) { return s * a; }
inline double dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double length(Vec3 a) { return std::sqrt(dot(a, a)); }
inline Vec3 normalize(Vec3 a) { return (1.0 / length(a)) * a; }
// Angle between two unit vectors in radians, accurate for tiny angles too.
inline double angle_between(Vec3 a, Vec3 b) { return std::atan2(length(cross(a, b)), dot(a, b)); }

// d = (sin t cos p, sin t sin p, cos t)
inline Vec3 direction_from_angles(double theta, double phi) {
  const double s = std::sin(theta);
  return {s * std::cos(phi), s * std::sin(phi), std::cos(theta)};
}
// Zenith theta in [0, pi] and azimuth phi in [0, 2 pi) of a unit vector.
inline double zenith_of(Vec3 d) { return std::acos(std::fmax(-1.0, std::fmin(1.0, d.z))); }
inline double azimuth_of(Vec3 d) {
  double p = std::atan2(d.y, d.x);
  return p < 0 ? p + 2 * M_PI : p;
}

// Row-major 3x3 matrix; used for rotations "b_from_a" that map a-frame vectors to b.
struct Mat3 {
  std::array<double, 9> m{1, 0, 0, 0, 1, 0, 0, 0, 1};
  double operator()(int r, int c) const { return m[3 * r + c]; }
};
inline Vec3 operator*(const Mat3& a, Vec3 v) {
  return {a(0, 0) * v.x + a(0, 1) * v.y + a(0, 2) * v.z, a(1, 0) * v.x + a(1, 1) * v.y + a(1, 2) * v.z,
          a(2, 0) * v.x + a(2, 1) * v.y + a(2, 2) * v.z};
}
inline Mat3 transpose(const Mat3& a) {
  return {{a(0, 0), a(1, 0), a(2, 0), a(0, 1), a(1, 1), a(2, 1), a(0, 2), a(1, 2), a(2, 2)}};
}
Mat3 operator*(const Mat3& a, const Mat3& b);
// Rotation from yaw (about +Z), pitch (about +Y), roll (about +X), in degrees, applied
// roll first: R = Rz(yaw) * Ry(pitch) * Rx(roll). This is the meaning of --rotation.
Mat3 rotation_from_yaw_pitch_roll_deg(double yaw, double pitch, double roll);
// Its inverse for a rotation: {yaw, pitch, roll} in degrees, pitch in [-90, 90], yaw and roll
// in (-180, 180]; at pitch +-90 (where only yaw - roll or yaw + roll is defined) roll is 0.
std::array<double, 3> yaw_pitch_roll_deg(const Mat3& r);
// True when a is orthonormal with determinant +1 to within tol.
bool is_rotation(const Mat3& a, double tol = 1e-6);
// The rotation nearest to a (in the Frobenius norm), for an a close to one (a matrix typed
// to a few decimals): orthonormal to rounding. a must have a positive determinant.
Mat3 nearest_rotation(const Mat3& a);

}  // namespace lp
