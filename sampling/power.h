// Shared finishing steps of every sampler.
#pragma once

#include <array>
#include <vector>

#include "core/envmap.h"
#include "core/light_list.h"

namespace lp {

// Scale each channel of the lights so that their sum equals `target` (the map's power).
// Equal-power methods give each light the colour of the pixel it landed on; this keeps
// the per-channel total exact without changing luminance ratios by more than the
// colour noise of the sample. Channels whose light sum is zero are left untouched.
void match_total_power(std::vector<Light>& lights, const std::array<double, 3>& target);

// The map as a row grid (latlong or hemisphere) for methods that work on rows;
// healpix maps are resampled to a latlong map with about as many pixels.
EnvMap as_row_grid(const EnvMap& map);

// Throws InputError unless the map has positive, finite total luminance power.
void require_samplable(const EnvMap& map, const char* method);
// For a sampler whose own single-precision sums came out empty or not finite: throws
// require_samplable's message, else says the map's values overflow those sums (a map with
// values near float's limit, 3e38), which an empty map's message misnamed.
[[noreturn]] void refuse_unsummable(const EnvMap& map, const char* method);

}  // namespace lp
