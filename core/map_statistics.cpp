#include "core/map_statistics.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <utility>
#include <vector>

namespace lp {

namespace {

// Share of the power in the brightest 0.1 % of the `valid` valid pixels.
double top_power_share(const EnvMap& map, size_t valid, double power_luminance) {
  if (valid == 0 || !(power_luminance > 0)) return 0;
  std::vector<std::pair<double, size_t>> by;
  by.reserve(valid);
  for (size_t i = 0; i < map.pixel_count(); ++i)
    if (map.is_valid(i)) {
      const float* p = map.pixel(i);
      by.emplace_back(luminance(p[0], p[1], p[2]) * pixel_solid_angle(map, i), i);
    }
  const size_t k = std::max<size_t>(1, valid / 1000);
  std::nth_element(by.begin(), by.begin() + long(k - 1), by.end(), std::greater<>());
  double top = 0;
  for (size_t i = 0; i < k; ++i) top += by[i].first;
  return top / power_luminance;
}

}  // namespace

MapStatistics map_statistics(const EnvMap& map) {
  MapStatistics s;
  s.pixels = map.pixel_count();
  std::vector<float> lum;
  lum.reserve(s.pixels);
  size_t brightest = 0;
  for (size_t i = 0; i < s.pixels; ++i) {
    if (!map.is_valid(i)) continue;
    ++s.valid;
    const float* p = map.pixel(i);
    const float y = luminance(p[0], p[1], p[2]);
    lum.push_back(y);
    if (y > s.max) s.max = y, brightest = i;
  }
  for (float y : lum)
    if (y > 0 && (s.min_positive == 0 || y < s.min_positive)) s.min_positive = y;
  auto quantile = [&](double q) {
    if (lum.empty()) return 0.0f;
    std::vector<float> v = lum;
    const size_t k = std::min(v.size() - 1, size_t(q * double(v.size() - 1) + 0.5));
    std::nth_element(v.begin(), v.begin() + long(k), v.end());
    return v[k];
  };
  s.median = quantile(0.5);
  s.p99 = quantile(0.99);
  s.power_rgb = total_power(map);
  s.power_luminance = luminance(s.power_rgb.data());
  for (float y : lum) s.mean += y;
  s.mean = lum.empty() ? 0 : s.mean / double(lum.size());
  s.range_stops = (s.min_positive > 0 && s.max > 0) ? std::log2(double(s.max) / s.min_positive) : 0;
  s.brightest_direction = s.pixels ? pixel_direction(map, brightest) : Vec3{};
  s.top_power_share = top_power_share(map, s.valid, s.power_luminance);
  return s;
}

nlohmann::json MapStatistics::to_json(const EnvMap& map) const {
  const Vec3 b = brightest_direction;
  nlohmann::json j = {
      {"layout", std::string(to_string(map.layout))},
      {"width", map.width},
      {"height", map.height},
      {"units", std::string(to_string(map.units))},
      {"pixels", pixels},
      {"valid_fraction", pixels ? double(valid) / double(pixels) : 0.0},
      {"luminance", {{"min_positive", min_positive}, {"max", max}, {"mean", mean}, {"median", median}, {"p99", p99}}},
      {"dynamic_range_stops", range_stops},
      {"power_rgb", {power_rgb[0], power_rgb[1], power_rgb[2]}},
      {"power_luminance", power_luminance},
      {"brightest_direction", {b.x, b.y, b.z}},
      {"power_share_top_0_1_percent", top_power_share},
  };
  if (map.layout == Layout::Healpix) j["nside"] = map.nside;
  return j;
}

}  // namespace lp
