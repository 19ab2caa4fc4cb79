// Filling the invalid pixels of an environment map (the blind spot behind a mirror
// ball, the ground below a fisheye's horizon, beyond its field of view) with values
// guessed from the valid ones, so that consumers which need a complete map (renderers,
// irradiance) get a plausible one. The mask is kept by default: filled pixels stay
// marked invalid, so that accuracy and sampling can still tell measured from guessed.
//
// Methods:
//   PushPull (default; Gortler et al. 1996 "The Lumigraph" §3.4.2): a pyramid of
//     weighted 2x2 means is built from the valid pixels (pull), then each level's
//     holes are filled from the bilinearly upsampled coarser level (push). The result
//     is a smooth membrane that reproduces the valid pixels exactly and reaches into
//     large holes with the mean colour of their rim. On latlong / hemisphere maps it runs
//     on the pixel grid with azimuth wrapping around; on healpix maps on the NESTED
//     hierarchy (parent = index / 4, children constant-upsampled).
//   Constant: every invalid pixel gets `constant_rgb` (e.g. a ground albedo guess).
//   None: leave the map untouched (the report still counts the invalid pixels).
#pragma once

#include <array>
#include <cstddef>

#include "core/envmap.h"

namespace lp {

enum class FillMethod { None, PushPull, Constant };

struct FillOptions {
  FillMethod method = FillMethod::PushPull;
  std::array<float, 3> constant_rgb{0.0f, 0.0f, 0.0f};  // Constant only
  // true (default): the mask is left as it was (filled pixels remain invalid);
  // false: the mask is cleared (every pixel valid) after filling.
  bool keep_mask = true;
};

struct FillReport {
  size_t filled_pixels = 0;         // pixels that were invalid
  double filled_solid_angle = 0;    // their exact solid angle, sr
  // Luminance power (sum Y * solid angle) of the filled pixels over that of the whole
  // map after filling (valid + filled): the share of the light that is guessed.
  double filled_power_share = 0;
};

// Throws InputError when the map's rgb / valid arrays do not match its size, or when
// PushPull is asked to fill a map with no valid pixel at all.
void fill_invalid(EnvMap& map, const FillOptions& options = {}, FillReport* report = nullptr);

}  // namespace lp
