#include "core/chromaticities.h"

#include <fmt/format.h>

#include <cmath>

#include "core/error.h"

namespace lp {
namespace {

using M3 = std::array<double, 9>;

M3 multiply(const M3& a, const M3& b) {
  M3 r{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) r[size_t(3 * i + j)] += a[size_t(3 * i + k)] * b[size_t(3 * k + j)];
  return r;
}

double determinant(const M3& m) {
  return m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) + m[2] * (m[3] * m[7] - m[4] * m[6]);
}

M3 inverse(const M3& m) {
  const double d = determinant(m);
  return {(m[4] * m[8] - m[5] * m[7]) / d, (m[2] * m[7] - m[1] * m[8]) / d, (m[1] * m[5] - m[2] * m[4]) / d,
          (m[5] * m[6] - m[3] * m[8]) / d, (m[0] * m[8] - m[2] * m[6]) / d, (m[2] * m[3] - m[0] * m[5]) / d,
          (m[3] * m[7] - m[4] * m[6]) / d, (m[1] * m[6] - m[0] * m[7]) / d, (m[0] * m[4] - m[1] * m[3]) / d};
}

std::array<double, 3> xyz_of(const std::array<double, 2>& xy) { return {xy[0] / xy[1], 1.0, (1 - xy[0] - xy[1]) / xy[1]}; }

// RGB -> XYZ of a set of primaries, white mapped to Y = 1 (the usual derivation: the
// primaries' XYZ columns scaled so that they sum to the white).
M3 rgb_to_xyz(const Chromaticities& c, const char* source) {
  // A primary may lie outside the spectral locus (AP0's blue has y = -0.077), but not on y = 0,
  // and the white must be a colour.
  for (const auto* xy : {&c.red, &c.green, &c.blue, &c.white})
    if ((*xy)[1] == 0 || !std::isfinite((*xy)[0]) || !std::isfinite((*xy)[1]))
      throw InputError(fmt::format("{}: chromaticities with y = 0 or not finite", source));
  if (!(c.white[1] > 0)) throw InputError(fmt::format("{}: a white point with y <= 0", source));
  const auto r = xyz_of(c.red), g = xyz_of(c.green), b = xyz_of(c.blue), w = xyz_of(c.white);
  const M3 p{r[0], g[0], b[0], r[1], g[1], b[1], r[2], g[2], b[2]};
  if (!(std::fabs(determinant(p)) > 1e-9))
    throw InputError(fmt::format("{}: chromaticities whose primaries span no colour space", source));
  const M3 pi = inverse(p);
  const double s[3] = {pi[0] * w[0] + pi[1] * w[1] + pi[2] * w[2], pi[3] * w[0] + pi[4] * w[1] + pi[5] * w[2],
                       pi[6] * w[0] + pi[7] * w[1] + pi[8] * w[2]};
  M3 m = p;
  for (int row = 0; row < 3; ++row)
    for (int col = 0; col < 3; ++col) m[size_t(3 * row + col)] *= s[col];
  return m;
}

// Bradford chromatic adaptation of XYZ from white `from` to white `to`.
M3 bradford(const std::array<double, 2>& from, const std::array<double, 2>& to) {
  const M3 b{0.8951, 0.2664, -0.1614, -0.7502, 1.7135, 0.0367, 0.0389, -0.0685, 1.0296};
  const auto cone = [&](const std::array<double, 3>& xyz) {
    return std::array<double, 3>{b[0] * xyz[0] + b[1] * xyz[1] + b[2] * xyz[2],
                                 b[3] * xyz[0] + b[4] * xyz[1] + b[5] * xyz[2],
                                 b[6] * xyz[0] + b[7] * xyz[1] + b[8] * xyz[2]};
  };
  const auto s = cone(xyz_of(from)), d = cone(xyz_of(to));
  const M3 scale{d[0] / s[0], 0, 0, 0, d[1] / s[1], 0, 0, 0, d[2] / s[2]};
  return multiply(inverse(b), multiply(scale, b));
}

}  // namespace

bool same_chromaticities(const Chromaticities& a, const Chromaticities& b, double tolerance) {
  const std::array<const std::array<double, 2>*, 4> pa{&a.red, &a.green, &a.blue, &a.white},
      pb{&b.red, &b.green, &b.blue, &b.white};
  for (size_t i = 0; i < 4; ++i)
    for (size_t k = 0; k < 2; ++k)
      if (!(std::fabs((*pa[i])[k] - (*pb[i])[k]) <= tolerance)) return false;
  return true;
}

std::array<double, 9> to_rec709_matrix(const Chromaticities& file, const char* source) {
  const M3 to_xyz = rgb_to_xyz(file, source);
  const M3 from_xyz = inverse(rgb_to_xyz(kRec709, source));
  const M3 m = multiply(from_xyz, multiply(bradford(file.white, kRec709.white), to_xyz));
  for (double v : m)
    if (!std::isfinite(v)) throw InputError(fmt::format("{}: chromaticities that give no finite conversion", source));
  return m;
}

}  // namespace lp
