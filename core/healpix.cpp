#include "core/healpix.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace lp {
namespace {

// The 12 base faces: the ring (in units of nside, from the north pole) of each face's
// southmost corner, and the longitude of its centre (in units of pi/4).
constexpr int kFaceRing[12] = {2, 2, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4};
constexpr int kFaceLongitude[12] = {1, 3, 5, 7, 0, 2, 4, 6, 1, 3, 5, 7};
constexpr double kHalfPi = std::numbers::pi / 2;
constexpr double kTwoPi = 2 * std::numbers::pi;
constexpr double kInvHalfPi = 0.6366197723675813430755350534900574;  // the double nearest 2/pi
// Near the poles z = cos(theta) loses the angle's precision; there sin(theta) is carried too.
constexpr double kPolarZ = 0.99;

// Bit i of v to bit 2i (a face's x, y -> the NESTED index's even, odd bits) and back.
uint64_t spread_bits(uint64_t v) {
  v = (v | (v << 16)) & 0x0000FFFF0000FFFFull;
  v = (v | (v << 8)) & 0x00FF00FF00FF00FFull;
  v = (v | (v << 4)) & 0x0F0F0F0F0F0F0F0Full;
  v = (v | (v << 2)) & 0x3333333333333333ull;
  return (v | (v << 1)) & 0x5555555555555555ull;
}
uint64_t compress_bits(uint64_t v) {
  v &= 0x5555555555555555ull;
  v = (v | (v >> 1)) & 0x3333333333333333ull;
  v = (v | (v >> 2)) & 0x0F0F0F0F0F0F0F0Full;
  v = (v | (v >> 4)) & 0x00FF00FF00FF00FFull;
  v = (v | (v >> 8)) & 0x0000FFFF0000FFFFull;
  return (v | (v >> 16)) & 0x00000000FFFFFFFFull;
}

// phi mod 2 pi in [0, 2 pi), as chealpix reduces it (so boundary pixels agree).
double wrap_longitude(double phi) {
  if (phi >= 0) return phi < kTwoPi ? phi : std::fmod(phi, kTwoPi);
  const double wrapped = std::fmod(phi, kTwoPi) + kTwoPi;
  return wrapped == kTwoPi ? 0.0 : wrapped;
}

}  // namespace

Vec3 healpix_direction(int64_t nside, int64_t pixel) {
  const int64_t face_pixels = nside * nside;
  const int face = int(pixel / face_pixels);
  const uint64_t in_face = uint64_t(pixel) & uint64_t(face_pixels - 1);
  const int64_t ix = int64_t(compress_bits(in_face)), iy = int64_t(compress_bits(in_face >> 1));
  const int64_t ring = kFaceRing[face] * nside - ix - iy - 1;  // 1 .. 4 nside - 1 from the north pole
  const double area = 4.0 / double(12 * face_pixels);          // 4 / npix
  int64_t ring_pixels;                                         // per quarter of the ring
  int64_t shift = 0;
  double z, sin_theta = -5;                                    // -5: not computed
  if (ring < nside) {                                          // north polar cap
    ring_pixels = ring;
    const double t = double(ring_pixels * ring_pixels) * area;
    z = 1 - t;
    if (z > kPolarZ) sin_theta = std::sqrt(t * (2. - t));
  } else if (ring > 3 * nside) {                               // south polar cap
    ring_pixels = 4 * nside - ring;
    const double t = double(ring_pixels * ring_pixels) * area;
    z = t - 1;
    if (z < -kPolarZ) sin_theta = std::sqrt(t * (2. - t));
  } else {                                                     // equatorial belt
    ring_pixels = nside;
    z = double(2 * nside - ring) * (double(nside << 1) * area);
    shift = (ring - nside) & 1;
  }
  int64_t column = (kFaceLongitude[face] * ring_pixels + ix - iy + 1 + shift) / 2;
  if (column > 4 * nside) column -= 4 * nside;
  if (column < 1) column += 4 * nside;
  const double phi = (double(column) - double(shift + 1) * 0.5) * (kHalfPi / double(ring_pixels));
  if (sin_theta < -2) sin_theta = std::sqrt((1. - z) * (1. + z));
  return {sin_theta * std::cos(phi), sin_theta * std::sin(phi), z};
}

int64_t healpix_pixel(int64_t nside, Vec3 d) {
  const double length = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
  const double z = d.z / length;
  const double sin_theta = std::fabs(z) > kPolarZ ? std::sqrt(d.x * d.x + d.y * d.y) / length : 0.0;  // unread
  return healpix_pixel_at(nside, z, sin_theta, wrap_longitude(std::atan2(d.y, d.x)));
}

int64_t healpix_pixel_at(int64_t nside, double z, double sin_theta, double phi) {
  const double za = std::fabs(z);
  const double tt = phi * kInvHalfPi;  // [0, 4)
  const double n = double(nside);
  int face;
  int64_t ix, iy;
  if (za <= 2.0 / 3.0) {  // equatorial belt: the two edge lines through the point
    const double t1 = n * (0.5 + tt), t2 = n * (z * 0.75);
    const int64_t ascending = int64_t(t1 - t2), descending = int64_t(t1 + t2);
    const int64_t fa = ascending / nside, fd = descending / nside;
    face = int(fa == fd ? (fa | 4) : (fa < fd ? fa : fd + 8));
    ix = descending & (nside - 1);
    iy = nside - (ascending & (nside - 1)) - 1;
  } else {  // polar caps
    const int quarter = std::min(int(tt), 3);
    const double tp = tt - quarter;
    const double t = za > kPolarZ ? n * sin_theta / std::sqrt((1. + za) / 3.) : n * std::sqrt(3 * (1 - za));
    const int64_t ascending = std::min(int64_t(tp * t), nside - 1);
    const int64_t descending = std::min(int64_t((1.0 - tp) * t), nside - 1);
    if (z >= 0) {
      face = quarter;
      ix = nside - descending - 1;
      iy = nside - ascending - 1;
    } else {
      face = quarter + 8;
      ix = ascending;
      iy = descending;
    }
  }
  return face * nside * nside + int64_t(spread_bits(uint64_t(ix))) + int64_t(spread_bits(uint64_t(iy)) << 1);
}

Vec3 healpix_point(int64_t nside, int64_t pixel, double u1, double u2) {
  const int64_t face_pixels = nside * nside;
  const int face = int(pixel / face_pixels);
  const uint64_t in_face = uint64_t(pixel) & uint64_t(face_pixels - 1);
  const double x = (double(compress_bits(in_face)) + u1) / double(nside);
  const double y = (double(compress_bits(in_face >> 1)) + u2) / double(nside);
  const double ring = kFaceRing[face] - x - y;  // in units of nside, from the north pole
  double ring_width, z, sin_theta;
  if (ring < 1) {
    ring_width = ring;
    const double t = ring_width * ring_width / 3.0;
    z = 1 - t;
    sin_theta = std::sqrt(t * (2.0 - t));  // accurate near the pole
  } else if (ring > 3) {
    ring_width = 4 - ring;
    const double t = ring_width * ring_width / 3.0;
    z = t - 1;
    sin_theta = std::sqrt(t * (2.0 - t));
  } else {
    ring_width = 1;
    z = (2 - ring) * 2.0 / 3.0;
    sin_theta = std::sqrt(std::max(0.0, (1 - z) * (1 + z)));
  }
  double t = kFaceLongitude[face] * ring_width + x - y;
  if (t < 0) t += 8;
  if (t >= 8) t -= 8;
  const double phi = ring_width < 1e-15 ? 0 : (0.25 * std::numbers::pi * t) / ring_width;
  return {sin_theta * std::cos(phi), sin_theta * std::sin(phi), z};
}

size_t healpix_nested_index(int nside, int face, int ix, int iy) {
  return size_t(face) * size_t(nside) * size_t(nside) + size_t(spread_bits(uint64_t(ix)) | (spread_bits(uint64_t(iy)) << 1));
}

void healpix_face_xy(int nside, size_t nested, int* face, int* ix, int* iy) {
  const size_t per_face = size_t(nside) * size_t(nside);
  *face = int(nested / per_face);
  const uint64_t in_face = nested % per_face;
  *ix = int(compress_bits(in_face));
  *iy = int(compress_bits(in_face >> 1));
}

}  // namespace lp
