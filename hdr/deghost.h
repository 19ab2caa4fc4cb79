// Ghost removal for exposure brackets: per pixel, which frames show the same scene as the
// reference frame (the middle exposure) and may therefore be merged there.
//
// Each frame's code value is brought to exposure-normalised log radiance,
// ln E = g(z) - ln t (g the log inverse response, or ln z for a linear camera), and compared
// with the reference's. A frame disagrees at a pixel, in any one channel, when
//   |ln E_i - ln E_ref| > ln(1 + relative_threshold) + noise_k * sqrt(s_i^2 + s_ref^2),
// s = noise_sigma * dg/dz the code noise carried into log radiance (so dark codes, whose
// relative noise is large, need a larger difference). Clipped codes are bounds, not values:
// a saturated code says ln E >= g(saturated_code - noise_k noise_sigma) - ln t, a black one
// ln E <= g(black_code + noise_k noise_sigma) - ln t. So each code states an interval of
// ln E (a point when usable), and a frame disagrees in a channel when its interval and the
// reference's lie apart by more than the tolerance above (noise terms of points only):
//   - both usable: the point test above;
//   - frame clipped, reference usable: the reference predicts the frame well inside its
//     range (a saturated frame where the reference predicts well below saturation);
//   - reference clipped: the frame contradicts the reference's bound. Where a bright
//     object saturates the reference, a shorter frame showing darker background there
//     (well below the bound) is the ghost and is dropped; a static bright pixel seen
//     unsaturated in the shorter frame is at or above the bound and is kept. Two bounds on
//     the same side never disagree; a saturated frame disagrees with a black reference
//     (and vice versa) when the bounds cannot both hold.
// If every other frame disagrees, the reference alone is kept there (the merge then uses its
// bound and flags the pixel). Where the reference pixel is invalid (RgbImage::valid), the
// valid frame closest to it in exposure order stands in as the anchor.
// Disagreeing pixels are dropped (mask 0), grown by dilate_px; invalid pixels
// (RgbImage::valid, e.g. shifted in by alignment) are dropped too. The reference keeps all
// its valid pixels.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/image_io.h"

namespace lp {

// Log inverse response per channel (R, G, B): entry k is g(z) = ln(E dt) at code
// z = k / (N - 1), N >= 2 entries (256 for 8-bit frames), increasing. Codes between entries
// are interpolated linearly. A response recovered as linear E dt per level (what
// cv::CalibrateDebevec returns) becomes this by taking its log.
using LogResponse = std::array<std::vector<float>, 3>;

struct DeghostOptions {
  // Largest relative disagreement of the exposure-normalised radiance tolerated beyond noise.
  double relative_threshold = 0.25;
  // Standard deviation of code noise, in code units ([0, 1]); two 8-bit levels by default
  // (quantisation plus sensor noise of a typical camera).
  double noise_sigma = 2.0 / 255.0;
  // How many standard deviations of noise are tolerated on top of relative_threshold.
  double noise_k = 3.0;
  // Codes at or below black_code only bound the radiance from above; at or above
  // saturated_code only from below.
  double black_code = 0.02;
  double saturated_code = 0.98;
  // Dropped regions grow by this many pixels (square structuring element), so the
  // interpolated edges of a moving object go too. 0 keeps the per-pixel decision.
  int dilate_px = 1;
  // Index of the reference frame; -1 is the middle exposure (middle_exposure_index).
  int reference = -1;
};

// Per frame, per pixel (row-major) keep masks: 1 merge this pixel of this frame, 0 drop it.
// `frames` hold code values in [0, 1]; `response` may be null (linear camera).
// Throws InputError when frames are empty, differ in size, their count does not match
// `exposure_seconds`, a time is not positive, or the response is malformed.
std::vector<std::vector<uint8_t>> ghost_masks(const std::vector<RgbImage>& frames,
                                              const std::vector<double>& exposure_seconds,
                                              const LogResponse* response = nullptr,
                                              const DeghostOptions& options = {});

// Number of dropped (0) pixels of each mask.
std::vector<size_t> count_dropped(const std::vector<std::vector<uint8_t>>& masks);

}  // namespace lp
