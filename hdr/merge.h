// Merging an exposure bracket into one relative-radiance image through a camera response:
// L = Σ_k w_k exp(g(z_k)) / t_k / Σ_k w_k per channel (Debevec & Malik 1997, eq. 6, in the
// linear domain), with hat weights on code values that drop clipped codes and, by
// default, the noise-aware factor t_k.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "core/image_io.h"
#include "hdr/bracket.h"
#include "hdr/response.h"

namespace lp {

struct MergeOptions {
  // Code values (in [0, 1]) at or below black_threshold or at or above
  // saturation_threshold carry no weight; between them the weight is a hat, 0 at both
  // thresholds and 1 halfway.
  double black_threshold = 0.02;
  double saturation_threshold = 0.98;
  // Multiply each frame's weight by its exposure time: for photon (Poisson) noise the
  // variance of z/t is ∝ E/t, so the inverse-variance weight of a frame is ∝ t. Where
  // quantisation rather than photon noise limits the error and the response is strongly
  // non-linear, it can hurt: on a noise-free 8-bit bracket through a film S-curve
  // (tests/hdr/merge_test.cpp) it doubles the median log10 error, 0.0026 vs 0.0012.
  bool exposure_weighting = true;
  // TBB worker threads (rows in parallel); 0 = TBB's default.
  int threads = 0;
  // Pixel/frame pairs of exactly this 8-bit colour (registration borders, pure blue in
  // Debevec's Memorial) get no weight; a pixel of this colour in every frame is invalid
  // in the output (RgbImage::valid) and counted in MergeReport::ignored.
  std::optional<std::array<uint8_t, 3>> ignore_colour;
  // Per-frame keep masks (e.g. ghost_masks in hdr/deghost.h): empty = keep everything, else
  // one width*height mask per frame, row-major, nonzero = merge this pixel of this frame,
  // 0 = drop it. Each frame's own RgbImage::valid (when non-empty; align_frames marks the
  // pixels it shifted in from outside) drops pixels the same way. Where no frame is kept a
  // pixel is invalid in the output and counted in MergeReport::no_frame; where kept frames
  // exist but all are clipped, the saturated/black bounds and flags below use the kept
  // frames only. Without masks and valid masks the merge takes its unmasked fast path.
  std::vector<std::vector<uint8_t>> frame_masks;
  // Fill MergeReport::flags (one byte per pixel).
  bool flag_image = false;
};

// Flag bits per pixel (MergeReport::flags).
enum MergeFlag : uint8_t {
  kSaturatedEverywhere = 1,  // some channel at or above saturation_threshold in every frame
  kBlackEverywhere = 2,      // some channel at or below black_threshold in every frame
};

struct MergeReport {
  // Pixels (not channels) with a channel that had no usable frame. A channel saturated in
  // every frame takes the shortest exposure's estimate (a lower bound); one black in every
  // frame takes the longest exposure's (an upper bound). Both stay valid in the image.
  size_t saturated_everywhere = 0;
  size_t black_everywhere = 0;
  size_t ignored = 0;  // pixels of ignore_colour in every kept frame (invalid in the output)
  size_t no_frame = 0;  // pixels that no frame_masks / frame valid mask kept (invalid in the output)
  double seconds = 0.0;
  std::vector<uint8_t> flags;  // width*height MergeFlag bits, when MergeOptions::flag_image
};

// Relative radiance (units Relative): code z of frame k maps to level
// lround(z · (levels − 1)) of `response`. Per-channel lookup tables and TBB over rows.
// Throws InputError on a bad bracket, a response with an unusable shape, or frame_masks /
// frame valid masks of the wrong count or size.
RgbImage merge_bracket(const Bracket& bracket, const CameraResponse& response, const MergeOptions& options = {},
                       MergeReport* report = nullptr);

}  // namespace lp
