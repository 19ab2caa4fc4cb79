// Ground-truth exposure brackets (`lightprobe synth bracket`): from any radiance image or
// map, the frames a camera with a known response, noise, bit depth, shake and a moving
// object would have taken. Deterministic: the same input and options give the same bits.
//
// Sensor model, per pixel and channel, for frame i with exposure time t_i:
//   X = L * exposure_scale * t_i                      normalised exposure; X = 1 fills the well
//   electrons = Poisson(X * full_well) + Normal(0, read_noise)     (when add_noise)
//   X' = electrons / full_well
//   z  = f(X'), clipped to [0, 1] (when clip) and rounded to 2^bit_depth - 1 levels
// with f the response curve:
//   Linear   z = X
//   Gamma22  z = X^(1/2.2)
//   SCurve   z = X^1.6 / (X^1.6 + 0.2^1.6) * (1 + 0.2^1.6): a film-like logistic in log
//            exposure, toe below X ~ 0.05, shoulder above, f(1) = 1 (sRGB-like contrast)
//   Custom   custom_response[k] = z at X = k / (size - 1), linear in between (increasing,
//            from 0 to 1); X > 1 gives z = 1
// true_log_exposure[c][z] = ln f^-1(z) - ln exposure_scale, Debevec's g(z): a perfect merge
// computes L = exp(g(z)) / t in the units of the input image. Level 0 and the top level
// hold g at half a level inside (ln 0 and saturation are not finite).
//
// exposure_scale = 0 (the default) chooses it so that the middle exposure (the median of
// exposure_seconds) puts the median luminance of the image at X = 0.18 (code 0.18 for a
// linear response).
// Shake: every frame but the reference (the middle one in the given order) is translated by
// a whole number of pixels, uniform in [-shake_px, shake_px] per axis:
//   frame(x, y) = scene(x - dx, y - dy), edge pixels repeated outside the image,
// so content moves by (+dx, +dy); true_shift_px[i] = {dx, dy}, {0, 0} for the reference.
// Moving object: a square of object_size_px (0: height / 8) and radiance object_radiance
// (0: 16x the median luminance, grey) crosses the image left to right at mid-height, one
// position per frame; true_radiance shows it where the reference frame does, and
// object_rect[i] = {x, y, w, h} records where it is in each frame (before shake).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/envmap.h"
#include "core/image_io.h"

namespace lp {

enum class ResponseCurve { Linear, Gamma22, SCurve, Custom };

struct SyntheticBracketOptions {
  std::vector<double> exposure_seconds{1 / 64., 1 / 8., 1.};  // 3 exposures, 3 stops apart
  ResponseCurve response = ResponseCurve::Linear;
  std::vector<double> custom_response;  // ResponseCurve::Custom only (see above)
  double exposure_scale = 0;            // 0: automatic (median -> 0.18 at the middle exposure)
  bool add_noise = true;
  double full_well_electrons = 10000;   // shot noise: electrons at X = 1
  double read_noise_electrons = 2;      // Gaussian sigma, electrons
  int bit_depth = 8;                    // 8, 12 or 16
  bool clip = true;                     // false: codes above 1 are kept (no saturation)
  int shake_px = 0;                     // max translation per frame and axis, pixels
  bool moving_object = false;
  int object_size_px = 0;               // 0: height / 8 (at least 1)
  double object_radiance = 0;           // 0: 16 x median luminance
  uint64_t seed = 1;
};

struct SyntheticBracket {
  std::vector<RgbImage> frames;  // code values in [0, 1], units Relative
  std::vector<double> exposure_seconds;
  std::array<std::vector<float>, 3> true_log_exposure;  // g(z) per level and channel
  RgbImage true_radiance;  // the input (with the moving object at its reference position)
  std::vector<std::array<double, 2>> true_shift_px;     // per frame {dx, dy}
  std::vector<std::array<int, 4>> object_rect;          // per frame {x, y, w, h}; empty without object
  double exposure_scale = 0;                            // the scale used
  int reference_frame = 0;                              // unshifted frame
};

// Throws InputError on bad options (no or non-positive exposure times, bit depth not
// 8/12/16, negative noise, a custom response that is not increasing from 0 to 1) or an
// image that is empty, has NaN/Inf/negative pixels, or a zero median with automatic scale.
SyntheticBracket make_synthetic_bracket(const RgbImage& radiance, const SyntheticBracketOptions& options = {});
// A map's pixels as an image (row-major latlong/hemisphere; healpix as one row).
RgbImage image_from_envmap(const EnvMap& map);

// The response curve f (normalised exposure X >= 0 -> code, unclipped) and its inverse.
double apply_response(const SyntheticBracketOptions& options, double x);
double invert_response(const SyntheticBracketOptions& options, double z);

// A bracket written as `hdr fuse` and `eval hdr` read it into `dir` (created): the
// frames as bit_depth PNGs (frame_NN.png), exposures.csv (file,seconds), the true
// radiance (truth.exr) and response (true_response.json, hdr/response.h's format).
void write_synthetic_bracket(const std::string& dir, const SyntheticBracket& bracket, int bit_depth);

}  // namespace lp
