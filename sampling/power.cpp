#include "sampling/power.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/resample.h"

namespace lp {

void match_total_power(std::vector<Light>& lights, const std::array<double, 3>& target) {
  const auto have = total_power(lights);
  for (int c = 0; c < 3; ++c) {
    if (!(have[c] > 0)) continue;
    const double s = target[c] / have[c];
    for (Light& l : lights) l.rgb[c] *= s;
  }
}

EnvMap as_row_grid(const EnvMap& map) {
  if (map.layout != Layout::Healpix) return map;
  // 12 nside^2 pixels -> 2H^2 latlong pixels: H = nside * sqrt(6), rounded.
  const int h = std::max(2, int(std::lround(map.nside * std::sqrt(6.0))));
  return resample(map, Layout::LatLong, 2 * h, h);
}

void require_samplable(const EnvMap& map, const char* method) {
  if (map.pixel_count() == 0) throw InputError(fmt::format("{}: the map is empty", method));
  const double p = total_luminance_power(map);
  if (!std::isfinite(p)) throw InputError(fmt::format("{}: the map has non-finite pixels", method));
  if (!(p > 0)) throw InputError(fmt::format("{}: the map is black (zero power): there is no light to sample", method));
}

void refuse_unsummable(const EnvMap& map, const char* method) {
  require_samplable(map, method);
  float top = 0;
  for (size_t i = 0; i < map.pixel_count(); ++i)
    if (map.is_valid(i)) top = std::max({top, map.pixel(i)[0], map.pixel(i)[1], map.pixel(i)[2]});
  throw InputError(fmt::format("{}: the map's power overflows single precision (values up to {:.3g}): scale the map down",
                               method, top));
}

}  // namespace lp
