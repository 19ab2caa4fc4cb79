// The unwrapping yardstick of CONVENTIONS.md: mean absolute log10 luminance error of an
// unwrapped map against the map a synthetic probe was rendered from, over the valid mask.
#pragma once

#include <cstddef>

#include "core/envmap.h"

namespace lp {

struct UnwrapError {
  double mean_abs_log10 = 0;       // over pixels valid in the estimate with both luminances > 0
  size_t pixels_compared = 0;
  size_t pixels_dark = 0;          // valid, but a luminance <= 0: no log, counted, left out
  double valid_solid_angle = 0;    // sr of the estimate's valid pixels
};

// Both maps must share layout and size (resample the truth first); throws InputError otherwise.
UnwrapError unwrap_error(const EnvMap& estimate, const EnvMap& truth);

}  // namespace lp
