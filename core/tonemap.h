// Tone mapping for pictures people look at (overlays, previews of probes and maps).
// Exposure k puts the `percentile` luminance of the valid pixels at `display` after
// Reinhard on luminance, c' = k c / (1 + k Y) per channel (hue kept, highlights
// compressed, not clipped); a pixel whose largest channel would still exceed 1 is scaled
// down as a whole. A given exposure (a temporal mapper's, core/temporal_tonemap.h) replaces
// the percentile's. Pixels not seen (invalid, or not finite) are drawn as a pattern,
// never black: a neutral grey checkerboard, or diagonal hatching on dark grey (the
// cartographer's "no data", which no map looks like; the live preview's choice).
// Output: linear display RGB in [0, 1] (write_display_image applies the sRGB encoding).
#pragma once

#include <cstdint>
#include <vector>

#include "core/image_view.h"

namespace lp {

enum class UnseenStyle { Checker, Hatch };

struct ToneMapOptions {
  double percentile = 0.99;  // luminance percentile of the valid pixels that sets exposure
  double display = 0.8;      // the display value it maps to
  double exposure = 0;       // > 0: this exposure k instead of the percentile's
  UnseenStyle unseen = UnseenStyle::Checker;
  int checker_px = 8;        // checkerboard square (hatching: line spacing is 1.5 x this)
};

// The sRGB transfer of one linear display value in [0, 1] to an 8-bit code (NaN and values
// <= 0 give 0, values >= 1 give 255): the one used by every picture (write_display_image).
uint8_t srgb_code(float linear);
// The inverse: IEC 61966-2-1's decoding of an sRGB-encoded value in [0, 1] to linear light.
double srgb_to_linear(double encoded);

// An RGB view (its mask, if any, marks the invalid pixels) -> packed display RGB, row-major.
std::vector<float> tone_map(ImageView image, const ToneMapOptions& options = {});

}  // namespace lp
