#include "render/env_distribution.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace lp {

namespace {

// NESTED index -> (face, ix, iy): within a face the index interleaves the bits of ix (even
// bits) and iy (odd bits).
uint32_t compact_even_bits(uint64_t v) {
  v &= 0x5555555555555555ull;
  v = (v | (v >> 1)) & 0x3333333333333333ull;
  v = (v | (v >> 2)) & 0x0F0F0F0F0F0F0F0Full;
  v = (v | (v >> 4)) & 0x00FF00FF00FF00FFull;
  v = (v | (v >> 8)) & 0x0000FFFF0000FFFFull;
  v = (v | (v >> 16)) & 0x00000000FFFFFFFFull;
  return uint32_t(v);
}

// HEALPix face coordinates (x, y) in [0, 1]^2 of base face f -> (z, phi): the inverse
// HEALPix projection, as xyf2loc of HEALPix C++ (Gorski et al. 2005, Calabretta & Roukema
// 2007). chealpix offers only pixel centres, hence this dozen lines.
Vec3 healpix_face_point(int face, double x, double y) {
  static const int jrll[12] = {2, 2, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4};
  static const int jpll[12] = {1, 3, 5, 7, 0, 2, 4, 6, 1, 3, 5, 7};
  const double jr = jrll[face] - x - y;
  double nr, z, sth;
  if (jr < 1) {
    nr = jr;
    const double tmp = nr * nr / 3.0;
    z = 1 - tmp;
    sth = std::sqrt(tmp * (2.0 - tmp));  // accurate near the pole
  } else if (jr > 3) {
    nr = 4 - jr;
    const double tmp = nr * nr / 3.0;
    z = tmp - 1;
    sth = std::sqrt(tmp * (2.0 - tmp));
  } else {
    nr = 1;
    z = (2 - jr) * 2.0 / 3.0;
    sth = std::sqrt(std::max(0.0, (1 - z) * (1 + z)));
  }
  double tmp = jpll[face] * nr + x - y;
  if (tmp < 0) tmp += 8;
  if (tmp >= 8) tmp -= 8;
  const double phi = nr < 1e-15 ? 0 : (0.25 * M_PI * tmp) / nr;
  return {sth * std::cos(phi), sth * std::sin(phi), z};
}

}  // namespace

Vec3 pixel_point(const EnvMap& map, size_t pixel, double u1, double u2) {
  if (map.layout == Layout::Healpix) {
    const uint64_t per_face = uint64_t(map.nside) * uint64_t(map.nside);
    const int face = int(pixel / per_face);
    const uint64_t p = pixel % per_face;
    const double ix = compact_even_bits(p), iy = compact_even_bits(p >> 1);
    return healpix_face_point(face, (ix + u1) / map.nside, (iy + u2) / map.nside);
  }
  const double span = map.layout == Layout::Hemisphere ? M_PI / 2 : M_PI;
  const size_t u = pixel % size_t(map.width), v = pixel / size_t(map.width);
  const double phi = 2 * M_PI * (double(u) + u1) / map.width;
  const double z0 = std::cos(span * double(v) / map.height), z1 = std::cos(span * double(v + 1) / map.height);
  const double z = z0 + u2 * (z1 - z0);
  const double s = std::sqrt(std::max(0.0, (1 - z) * (1 + z)));
  return {s * std::cos(phi), s * std::sin(phi), z};
}

EnvDistribution::EnvDistribution(EnvMap map, const EnvDistributionOptions& options) : map_(std::move(map)) {
  if (map_.pixel_count() == 0 || map_.rgb.size() != 3 * map_.pixel_count())
    throw InputError("environment distribution: the map has no pixels");
  if (!(options.uniform_share >= 0 && options.uniform_share <= 1))
    throw InputError(fmt::format("environment distribution: uniform_share must be in [0, 1], got {}", options.uniform_share));
  if (const std::string bad = find_bad_pixel(map_, "environment distribution"); !bad.empty()) throw InputError(bad);
  const size_t n = map_.pixel_count();
  solid_angle_.resize(n);
  std::vector<double> weight(n, 0.0), area(n, 0.0);
  double weight_sum = 0, area_sum = 0;
  for (size_t i = 0; i < n; ++i) {
    solid_angle_[i] = lp::pixel_solid_angle(map_, i);
    if (!map_.is_valid(i)) continue;
    const float* p = map_.pixel(i);
    weight[i] = double(lp::luminance(p[0], p[1], p[2])) * solid_angle_[i];
    area[i] = solid_angle_[i];
    weight_sum += weight[i];
    area_sum += area[i];
  }
  luminance_power_ = weight_sum;
  if (!(weight_sum > 0))
    throw InputError(fmt::format("environment distribution: the map ({}) is black: every valid pixel has zero luminance",
                                 describe_size(map_)));
  cdf_.resize(n);
  double acc = 0;
  const double s = options.uniform_share;
  for (size_t i = 0; i < n; ++i) {
    acc += (1 - s) * weight[i] / weight_sum + (s > 0 ? s * area[i] / area_sum : 0.0);
    cdf_[i] = acc;
  }
  // Normalise away rounding so that the last entry is exactly 1.
  for (double& c : cdf_) c /= acc;
}

double EnvDistribution::pixel_probability(size_t pixel) const {
  return pixel == 0 ? cdf_[0] : cdf_[pixel] - cdf_[pixel - 1];
}

EnvSample EnvDistribution::sample(const std::array<double, 3>& u) const {
  // First entry with cdf > u: pixels of zero probability (equal cdf to the previous) are
  // never chosen.
  auto it = std::upper_bound(cdf_.begin(), cdf_.end(), u[0]);
  if (it == cdf_.end()) --it;
  size_t i = size_t(it - cdf_.begin());
  while (pixel_probability(i) <= 0 && i > 0) --i;  // u[0] at the very top, rounding
  EnvSample s;
  s.pixel = i;
  s.direction = pixel_point(map_, i, u[1], u[2]);
  s.pdf = pixel_probability(i) / solid_angle_[i];
  const float* p = map_.pixel(i);
  s.radiance = {p[0], p[1], p[2]};
  return s;
}

double EnvDistribution::pdf(Vec3 d) const {
  const auto i = pixel_at(map_, d);
  if (!i || !map_.is_valid(*i)) return 0;
  return pixel_probability(*i) / solid_angle_[*i];
}

Rgb EnvDistribution::radiance(Vec3 d) const {
  const auto i = pixel_at(map_, d);
  if (!i || !map_.is_valid(*i)) return {0, 0, 0};
  const float* p = map_.pixel(*i);
  return {p[0], p[1], p[2]};
}

double EnvDistribution::luminance(Vec3 d) const {
  const Rgb r = radiance(d);
  return lp::luminance(r.data());
}

}  // namespace lp
