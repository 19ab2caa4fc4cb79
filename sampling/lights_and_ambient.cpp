#include "sampling/lights_and_ambient.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "core/error.h"
#include "core/spherical_harmonics.h"

namespace lp {

namespace {

// tau: walking the valid pixels from the brightest, the luminance where their solid
// angle first exceeds `budget`.
double peak_threshold(const EnvMap& map, double budget) {
  std::vector<std::pair<float, float>> pixels;  // (luminance, solid angle)
  pixels.reserve(map.pixel_count());
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    if (!map.is_valid(i)) continue;
    const float* p = map.pixel(i);
    pixels.emplace_back(luminance(p[0], p[1], p[2]), float(pixel_solid_angle(map, i)));
  }
  std::sort(pixels.begin(), pixels.end(), [](auto a, auto b) { return a.first > b.first; });
  double covered = 0;
  for (const auto& [y, dw] : pixels) {
    covered += dw;
    if (covered > budget) return y;
  }
  return 0;  // the budget covers the whole map: everything goes to the lights
}

}  // namespace

PeakSplit split_peaks(const EnvMap& map, int n, const LightsAndAmbientOptions& options) {
  if (n <= 0) throw InputError(fmt::format("--n must be positive, got {}", n));
  const double cap = 2 * M_PI * (1 - std::cos(options.light_cap_deg * M_PI / 180));
  PeakSplit s;
  s.threshold = peak_threshold(map, n * cap);
  s.peaks = map;
  s.residual = map;
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    if (!map.is_valid(i)) continue;
    const float* p = map.pixel(i);
    const double y = luminance(p[0], p[1], p[2]);
    const double keep = y > s.threshold ? s.threshold / y : 1.0;  // residual share of the pixel
    for (int c = 0; c < 3; ++c) {
      s.residual.pixel(i)[c] = float(p[c] * keep);
      s.peaks.pixel(i)[c] = p[c] - s.residual.pixel(i)[c];
    }
  }
  return s;
}

LightsAndAmbient sample_lights_and_sh9(const EnvMap& map, int n, Method method, const SamplerOptions& sampler,
                                       const LightsAndAmbientOptions& options) {
  if (const std::string bad = find_bad_pixel(map, "map"); !bad.empty()) throw InputError(bad);
  const PeakSplit split = split_peaks(map, n, options);
  LightsAndAmbient out;
  out.threshold = split.threshold;
  const double peak_power = total_luminance_power(split.peaks);
  if (peak_power > 0) {
    out.list = sample(split.peaks, n, method, sampler);
  } else {
    out.list.method = std::string(to_string(method));
    out.list.units = map.units;
  }
  out.list.sh9 = project_sh9(split.residual);
  out.list.sh9_content = Sh9Content::Residual;
  const double total = total_luminance_power(map);
  out.light_power_share = total > 0 ? peak_power / total : 0;
  return out;
}

AmbientComparison compare_lights_and_sh9(const EnvMap& map, const AccuracyReference& reference, int n, Method method,
                                         const SamplerOptions& sampler, const LightsAndAmbientOptions& options) {
  AmbientComparison c;
  const LightsAndAmbient both = sample_lights_and_sh9(map, n, method, sampler, options);
  c.light_power_share = both.light_power_share;
  c.lights_and_sh9 = light_error(reference, both.list.lights, *both.list.sh9);
  c.list = both.list;
  c.lights_only = light_error(reference, sample(map, n, method, sampler).lights);
  c.sh9_only = light_error(reference, {}, project_sh9(map));
  return c;
}

}  // namespace lp
