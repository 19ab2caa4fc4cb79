// Angular regions: Fibonacci centres, an OpenGL-convention cube-map LUT, measured radii,
// and per-region light lists. See angular_regions.h for the definitions.
#include "render/angular_regions.h"

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "core/accuracy.h"
#include "core/error.h"

namespace lp {

int cube_texel_of(Vec3 d, int n) {
  const double ax = std::fabs(d.x), ay = std::fabs(d.y), az = std::fabs(d.z);
  int face;
  double sc, tc, ma;
  if (ax >= ay && ax >= az) {
    face = d.x >= 0 ? 0 : 1;
    ma = ax;
    sc = d.x >= 0 ? -d.z : d.z;
    tc = -d.y;
  } else if (ay >= az) {
    face = d.y >= 0 ? 2 : 3;
    ma = ay;
    sc = d.x;
    tc = d.y >= 0 ? d.z : -d.z;
  } else {
    face = d.z >= 0 ? 4 : 5;
    ma = az;
    sc = d.z >= 0 ? d.x : -d.x;
    tc = -d.y;
  }
  if (!(ma > 0)) return 0;  // the zero vector (or NaN): any region is as good
  const int s = std::clamp(int(std::floor(n * 0.5 * (sc / ma + 1))), 0, n - 1);
  const int t = std::clamp(int(std::floor(n * 0.5 * (tc / ma + 1))), 0, n - 1);
  return (face * n + t) * n + s;
}

Vec3 cube_texel_direction(int index, int n, double fs, double ft) {
  const int face = index / (n * n);
  const int t = (index / n) % n, s = index % n;
  const double sc = 2 * (s + fs) / n - 1, tc = 2 * (t + ft) / n - 1;
  Vec3 d;
  switch (face) {
    case 0: d = {1, -tc, -sc}; break;
    case 1: d = {-1, -tc, sc}; break;
    case 2: d = {sc, 1, tc}; break;
    case 3: d = {sc, -1, -tc}; break;
    case 4: d = {sc, -tc, 1}; break;
    default: d = {-sc, -tc, -1}; break;
  }
  return normalize(d);
}

AngularRegions::AngularRegions(const AngularRegionOptions& options) : face_size_(options.lut_face_size) {
  if (options.regions < 1)
    throw InputError(fmt::format("angular regions: the number of regions must be at least 1, got {}", options.regions));
  if (options.lut_face_size < 1)
    throw InputError(fmt::format("angular regions: the LUT face size must be at least 1, got {}", options.lut_face_size));
  centres_ = fibonacci_sphere(options.regions);
  const int m = count();
  const size_t mm = static_cast<size_t>(m);
  std::vector<float> cx(mm), cy(mm), cz(mm);
  for (int j = 0; j < m; ++j) cx[size_t(j)] = float(centres_[size_t(j)].x), cy[size_t(j)] = float(centres_[size_t(j)].y),
                              cz[size_t(j)] = float(centres_[size_t(j)].z);
  const int texels = 6 * face_size_ * face_size_;
  lut_.assign(size_t(texels), 0);
  // Nearest centre to each texel centre: a brute-force scan (done once, not per frame).
  tbb::parallel_for(0, texels, [&](int i) {
    const Vec3 d = cube_texel_direction(i, face_size_);
    const float x = float(d.x), y = float(d.y), z = float(d.z);
    float best = -2;
    int arg = 0;
    for (int j = 0; j < m; ++j) {
      const float c = x * cx[size_t(j)] + y * cy[size_t(j)] + z * cz[size_t(j)];
      if (c > best) best = c, arg = j;
    }
    lut_[size_t(i)] = arg;
  });
  // Radius: farthest texel corner of each region (corners bound the texel, see header).
  radius_.assign(size_t(m), 0.0);
  for (int i = 0; i < texels; ++i) {
    const int j = lut_[size_t(i)];
    for (double fs : {0.0, 1.0})
      for (double ft : {0.0, 1.0})
        radius_[size_t(j)] =
            std::max(radius_[size_t(j)], angle_between(centres_[size_t(j)], cube_texel_direction(i, face_size_, fs, ft)));
  }
}

double AngularRegions::max_radius() const { return *std::max_element(radius_.begin(), radius_.end()); }

RegionLights assign_lights(const AngularRegions& regions, std::span<const Light> lights, double reach) {
  if (!(reach >= 0)) throw InputError(fmt::format("angular regions: the reach must be >= 0 rad, got {}", reach));
  const int m = regions.count();
  std::vector<std::vector<uint32_t>> lists(static_cast<size_t>(m));
  tbb::parallel_for(0, m, [&](int j) {
    const Vec3 p = regions.centres()[size_t(j)];
    const double limit = regions.radius()[size_t(j)] + reach + 1e-6;
    if (limit >= M_PI) {  // the region sees every direction
      lists[size_t(j)].resize(lights.size());
      for (size_t i = 0; i < lights.size(); ++i) lists[size_t(j)][i] = uint32_t(i);
      return;
    }
    const double min_cos = std::cos(limit);
    auto& list = lists[size_t(j)];
    for (size_t i = 0; i < lights.size(); ++i)
      if (dot(p, lights[i].direction) >= min_cos) list.push_back(uint32_t(i));
  });
  RegionLights out;
  out.reach = reach;
  out.offsets.resize(size_t(m) + 1);
  size_t total = 0;
  for (int j = 0; j < m; ++j) out.offsets[size_t(j)] = uint32_t(total), total += lists[size_t(j)].size();
  out.offsets[size_t(m)] = uint32_t(total);
  out.indices.reserve(total);
  for (auto& l : lists) out.indices.insert(out.indices.end(), l.begin(), l.end());
  return out;
}

}  // namespace lp
