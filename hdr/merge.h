// Merging an exposure bracket into one relative-radiance image through a camera response:
// L = Σ_k w_k exp(g(z_k)) / t_k / Σ_k w_k per channel (Debevec & Malik 1997, eq. 6, in the
// linear domain), with hat weights on code values that drop clipped codes, times the
// factor t_k (default) or the inverse variance of a sensor noise model (MergeOptions::weighting).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/image_io.h"
#include "core/image_view.h"
#include "hdr/bracket.h"
#include "hdr/response.h"

namespace lp {

struct MergeOptions {
  // Code values (in [0, 1]) at or below black_threshold or at or above
  // saturation_threshold carry no weight; between them the weight is a hat, 0 at both
  // thresholds and 1 halfway.
  double black_threshold = 0.02;
  double saturation_threshold = 0.98;
  // How each frame's code value is weighted (the weight of frame k at code z, per channel):
  //   Hat               hat(z)
  //   HatTimesExposure  hat(z) * t_k: for photon (Poisson) noise the variance of z/t is
  //                     ∝ E/t, so the inverse-variance weight of a frame is ∝ t. Where
  //                     quantisation rather than photon noise limits the error and the
  //                     response is strongly non-linear, it can hurt: on a noise-free 8-bit
  //                     bracket through a film S-curve (tests/hdr/merge_test.cpp) it doubles
  //                     the median log10 error, 0.0026 vs 0.0012.
  //   NoiseAware        (default) hat(z) / var(E_k): the inverse variance of frame k's
  //                     estimate E_k = exp(g(z)) / t_k under a sensor model (Robertson et al.
  //                     2003, Granados et al. 2010), with g = ln(E t) the response:
  //                       X(z) = exp(g(z) - g(saturation_threshold))   exposure, 1 = full well
  //                       sigma_z^2 = q^2/12                            quantisation, q = one code step
  //                                 + (sigma_X / X'(z))^2               sensor noise through the response
  //                       sigma_X^2 = X / N + (r / N)^2                 shot + read noise (N = noise_full_well,
  //                                                                     r = noise_read_electrons)
  //                       var(ln E_k) = (g'(z) sigma_z)^2
  //                                   = g'(z)^2 q^2/12 + 1/(N X) + (r/(N X))^2   (X' = X g')
  //                       var(E_k) = E_k^2 var(ln E_k)   at the frame's own E_k, so the weight is
  //                       hat(z) exp(-2 g(z)) / var(ln E_k)  per level  ×  t_k^2  per frame
  //                     g' (per code unit) is a central difference of the response table over
  //                     ±(levels−1)/64 levels, so a flat response (toe, shoulder: g' large) gets
  //                     almost no weight; q = 1/(min(2^bit_depth, levels) − 1). Where frames
  //                     agree, the E_k^2 factor is common and this is the inverse variance of
  //                     ln E (shot-noise limited: ∝ t, as HatTimesExposure). Where one is biased
  //                     high, it weighs less: on Memorial, pixels at the film's fog floor
  //                     (code ~19 in every frame) otherwise take the short frames' far too
  //                     bright estimates (with var(ln E) alone, p95 0.171 instead of 0.046).
  // Every weighting is a per-level table times a per-frame factor, precomputed once: the
  // per-pixel cost is the same for all three.
  enum class Weighting { Hat, HatTimesExposure, NoiseAware };
  Weighting weighting = Weighting::NoiseAware;
  // Sensor constants of NoiseAware: electrons at the saturation code (full well) and the
  // read-noise sigma in electrons. Only their ratios to the quantisation term matter; the
  // defaults (10 000 e-, 2 e-) are a small-pixel sensor's, as in hdr/synthetic_bracket.h.
  double noise_full_well = 10000.0;
  double noise_read_electrons = 2.0;
  // Legacy switch (CLI --no-exposure-weighting): false merges with plain Hat weights
  // whatever `weighting` says (NoiseAware, too, trusts long exposures more).
  // Measured (tests/hdr/merge_weights_test.cpp, DISABLED_WeightingTable; median/p95 log10
  // error): Memorial vs Debevec's HDRShop map, our Debevec g: Hat 0.149/1.12, HatTimesExposure
  // 0.0114/0.0546, NoiseAware 0.0101/0.0457; 3-frame synthetic brackets (grace, pisa, uffizi,
  // procedural scene; gamma and S-curve; true and recovered g): NoiseAware within 0.5 % of
  // HatTimesExposure on 10 of 16, 0.6-2.2 % worse on 6 (S-curve; worst pisa, true g, 0.00427/
  // 0.01391 vs 0.00418/0.01366); Hat up to 50 % worse (pisa gamma).
  bool exposure_weighting = true;
  // TBB worker threads (rows in parallel); 0 = TBB's default.
  int threads = 0;
  // true (default): the unmasked merge (no frame_masks, valid masks or ignore_colour) runs a
  // vector kernel (hdr/merge_kernel.h, Google Highway, the best of SSSE3/SSE4/AVX2/AVX-512
  // chosen at run time; ~7x faster with AVX-512 on the benchmark's bracket, docs/hdr.md);
  // false: the scalar loop, kept as its reference. The two give the same image, flags and counts bit for bit
  // (tests/hdr/merge_kernel_test.cpp). Masked merges and ignore_colour run the scalar loop.
  bool simd = true;
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
  size_t well_exposed = 0;  // pixels whose every channel had a usable frame (none: InputError)
  double seconds = 0.0;
  std::vector<uint8_t> flags;  // width*height MergeFlag bits, when MergeOptions::flag_image
};

// Relative radiance (units Relative): code z of frame k maps to level
// lround(z · (levels − 1)) of `response`. Per-channel lookup tables and TBB over rows.
// Throws InputError on a bad bracket, a response with an unusable shape, frame_masks /
// frame valid masks of the wrong count or size, or a bracket in which no pixel is well
// exposed in any frame (all black or all saturated: nothing was measured).
RgbImage merge_bracket(const Bracket& bracket, const CameraResponse& response, const MergeOptions& options = {},
                       MergeReport* report = nullptr);
// The same over frames someone else owns (camera buffers, a live ring): non-owning RGB views
// of one size (any row stride), with their exposure times. bracket_view(b) makes one of a
// Bracket (valid while it lives, with its 8-bit codes when it has them); merging it gives the
// same image bit for bit.
struct BracketView {
  std::vector<ImageView> frames;
  std::vector<double> exposure_seconds;
  int bit_depth = 8;
  std::string label = "bracket";  // names the bracket in errors
  // Optional, per frame: packed RGB bytes (3 * width per row, rows in order), the level of
  // every code value of frames[k] at 256 levels (Bracket::codes, keep_8bit_codes). With a
  // 256-level response the merge reads these instead of the floats (their valid masks still
  // count): 11 MB instead of 44 for 3 frames of 1280x960, the same image, flags and counts.
  std::vector<const uint8_t*> codes;
};
BracketView bracket_view(const Bracket& bracket);
RgbImage merge_bracket(const BracketView& bracket, const CameraResponse& response, const MergeOptions& options = {},
                       MergeReport* report = nullptr);
// The same into *out, whose storage is reused when it already holds an image of the frames'
// size: a stream or a benchmark merging bracket after bracket allocates and zero-fills no
// 15 MB output per call (a single-threaded memset, 7 % of the 2-thread merge's CPU at
// 1280x960). Every value of out->rgb is overwritten; out->valid as merge_bracket returns it.
void merge_bracket(const BracketView& bracket, const CameraResponse& response, const MergeOptions& options,
                   RgbImage* out, MergeReport* report = nullptr);

// The merge's weights, as merge_bracket precomputes them: frame k's weight at code level l
// of channel c is level[c][l] * frame[k] (0 outside the thresholds). Throws InputError on a
// response of the wrong shape, no exposure times or bad noise constants.
struct MergeWeights {
  std::array<std::vector<float>, 3> level;
  std::vector<float> frame;
};
MergeWeights merge_weights(const CameraResponse& response, int bit_depth, const std::vector<double>& exposure_seconds,
                           const MergeOptions& options = {});

}  // namespace lp
