// The HDR accuracy measure of CONVENTIONS.md: on an estimate of a known radiance image,
// the median and 95th-percentile absolute error of log10 luminance after one global scale.
//
//   Y = 0.2126 R + 0.7152 G + 0.0722 B per pixel, estimate and truth
//   compared pixels: in the mask (if any), valid in the truth (its own mask) with a finite
//                    truth luminance > 0 (log10 0 is not a number; the others are counted in
//                    pixels_truth_dark)
//   invalid pixels:  compared pixels whose estimate luminance is 0, negative, NaN or Inf, or
//                    that the estimate's own mask marks invalid; counted in pixels_invalid and
//                    left out of the statistics (an estimate that blanks hard pixels shows it)
//   global scale:    s = median over the remaining pixels of log10(Y_truth / Y_estimate);
//                    global_scale = 10^s multiplies the estimate (relative units carry no
//                    absolute scale; the median is robust to a few bad pixels)
//   error:           e = |log10(Y_estimate) + s - log10(Y_truth)|; median_log10 and p95_log10
//                    (nearest rank: the value at index ceil(0.95 n) - 1 of the sorted errors)
// pixels_compared counts the pixels in the statistics (invalid ones excluded).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "core/image_io.h"

namespace lp {

struct HdrError {
  double median_log10 = 0;
  double p95_log10 = 0;
  size_t pixels_compared = 0;
  size_t pixels_invalid = 0;  // 0, negative, NaN, Inf or masked out in the estimate
  size_t pixels_truth_dark = 0;  // truth luminance 0 (or not finite): no log, left out
  double global_scale = 1;    // applied to the estimate
};

// `mask`: one byte per pixel, nonzero = compare (e.g. Memorial's registration border out).
// Throws InputError when the sizes differ or no pixel can be compared.
HdrError hdr_log_error(const RgbImage& estimate, const RgbImage& truth,
                       const std::optional<std::vector<uint8_t>>& mask = std::nullopt);

}  // namespace lp
