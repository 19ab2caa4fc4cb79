#include "probe/unwrap_accuracy.h"

#include <fmt/format.h>

#include <cmath>

#include "core/error.h"

namespace lp {

UnwrapError unwrap_error(const EnvMap& estimate, const EnvMap& truth) {
  if (estimate.layout != truth.layout || estimate.width != truth.width || estimate.height != truth.height)
    throw InputError(fmt::format("unwrap error: maps differ ({} vs {})", describe_size(estimate), describe_size(truth)));
  UnwrapError e;
  double sum = 0;
  for (size_t i = 0; i < estimate.pixel_count(); ++i) {
    if (!estimate.is_valid(i)) continue;
    e.valid_solid_angle += pixel_solid_angle(estimate, i);
    const float* a = estimate.pixel(i);
    const float* b = truth.pixel(i);
    const double ya = luminance(a[0], a[1], a[2]), yb = luminance(b[0], b[1], b[2]);
    if (!(ya > 0) || !(yb > 0)) {
      ++e.pixels_dark;
      continue;
    }
    sum += std::fabs(std::log10(ya / yb));
    ++e.pixels_compared;
  }
  e.mean_abs_log10 = e.pixels_compared ? sum / double(e.pixels_compared) : 0;
  return e;
}

}  // namespace lp
