#include "render/env_distribution.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/healpix.h"

namespace lp {

Vec3 pixel_point(const EnvMap& map, size_t pixel, double u1, double u2) {
  if (map.layout == Layout::Healpix) {
    return healpix_point(map.nside, int64_t(pixel), u1, u2);
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
