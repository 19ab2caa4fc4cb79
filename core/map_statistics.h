// What `lightprobe info` reports of a map: validity, the luminance distribution, dynamic
// range, power and how peaky the map is (the share of the power in its brightest pixels).
#pragma once

#include <nlohmann/json.hpp>

#include <array>
#include <cstddef>

#include "core/envmap.h"
#include "core/vec3.h"

namespace lp {

struct MapStatistics {
  size_t pixels = 0, valid = 0;
  // Luminance of the valid pixels (Rec. 709); quantiles are the nearest-rank pixel values.
  float min_positive = 0, max = -1, median = 0, p99 = 0;
  double mean = 0;
  double range_stops = 0;               // log2(max / min_positive); 0 when either is 0
  std::array<double, 3> power_rgb{};    // total_power (core/envmap.h)
  double power_luminance = 0;
  Vec3 brightest_direction;             // of the brightest valid pixel ({} for an empty map)
  double top_power_share = 0;           // share of the power in the brightest 0.1 % of valid pixels
  // Keys as `lightprobe info --json`: layout, width, height, units, pixels, valid_fraction,
  // luminance {min_positive, max, mean, median, p99}, dynamic_range_stops, power_rgb,
  // power_luminance, brightest_direction, power_share_top_0_1_percent (nside for HEALPix).
  nlohmann::json to_json(const EnvMap& map) const;
};

MapStatistics map_statistics(const EnvMap& map);

}  // namespace lp
