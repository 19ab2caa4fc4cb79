// The merge's vector kernel (hdr/merge_kernel.cpp): one row of the unmasked merge
// (hdr/merge.cpp, merge_rows without frame masks, valid masks or ignore_colour) in Google
// Highway, compiled for every x86 target Highway knows (SSSE3, SSE4, AVX2, AVX-512, and
// its scalar fallback) and dispatched at run time to the best one the CPU has. Internal to
// hdr/: merge_bracket calls it, tests/hdr/merge_kernel_test.cpp compares it with the
// scalar loop on every compiled target.
#pragma once

#include <cstddef>
#include <cstdint>

namespace lp::detail {

struct MergeRowInput {
  const float* const* rows;  // per frame: one row of packed RGB code values in [0, 1]
  // Or, with 256 levels: per frame, the row's levels as packed RGB bytes (BracketView::codes),
  // read instead of `rows` when not null.
  const uint8_t* const* codes = nullptr;
  const float* frame_w;      // per frame: s_k (the weighting's frame factor)
  const float* frame_wx;     // per frame: s_k / t_k
  size_t frames = 0;
  size_t width = 0;          // pixels in the row
  // Per-level tables of the three channels, channel-major: w[c * levels + l] = hat(l) (times
  // the level's noise weight), wx[c * levels + l] = w[c * levels + l] * exp(g_c(l)).
  const float* w = nullptr;
  const float* wx = nullptr;
  const uint64_t* w_wx = nullptr;  // both as one 64-bit entry each: the bits of w in the low half, wx in the high
  int levels = 0;
  // Levels at or below zero_through and at or above zero_from have w = wx = 0 in all three
  // channels (the hat's black and clipped ends). A frame whose vector of codes lies there in
  // every lane adds +0 to non-negative sums, which changes no bit: its table reads are skipped.
  int zero_through = -1;
  int zero_from = 0;
  // The bounds of a channel no frame weighs (MergeReport): at or above sat_level in every
  // frame, the shortest frame's estimate; at or below black_level in every frame, the longest
  // frame's. Tables of float(exp(g_c(l)) / t_k) for those two frames, channel-major as w.
  int sat_level = 0, black_level = 0;
  size_t shortest = 0, longest = 0;
  const float* bound_short = nullptr;
  const float* bound_long = nullptr;
  // For 256 levels: w, wx, bound_short and bound_long as byte planes, table-major, then
  // channel, then byte p of the float (little-endian) at [level]: ((t * 3 + c) * 4 + p) * 256
  // + level. merge_row_vbmi reads these; null without them.
  const uint8_t* planes = nullptr;
  // The three channels' w tables are one table, and so are their wx tables (a response
  // that is the same curve for R, G and B: the linear default, sRGB). merge_row_vbmi then
  // reads 8-bit codes as they lie, interleaved, without splitting them into channel planes.
  bool one_table = false;
};

// Writes out[3x + c] = Σ_k wx(z) s_k/t_k / Σ_k w(z) s_k, summed over frames in order, with
// the scalar loop's operations and order (bit-identical), for the pixels x < done (a multiple
// of the vector width; the rest are the caller's). A channel of zero total weight takes the
// bound above; its pixel is counted in `saturated` / `black` and, when flags is not null,
// flags[x] (zeroed by the caller) gets kSaturatedEverywhere / kBlackEverywhere (hdr/merge.h).
// Pixels with a channel of zero weight that is neither (clipped in some frames, black in the
// others: rare) are listed in `redo` (room for `width` entries), `redone` of them, neither
// flagged nor counted: the caller's scalar loop finishes them.
struct MergeRowResult {
  size_t done = 0;       // pixels written
  size_t redone = 0;     // pixels listed in redo
  size_t saturated = 0;  // pixels with kSaturatedEverywhere
  size_t black = 0;      // pixels with kBlackEverywhere
  size_t flagged = 0;    // pixels with either (the rest of done minus redone are well exposed)
};
MergeRowResult merge_row_simd(const MergeRowInput& in, float* out, uint8_t* flags, uint32_t* redo);

// The same for CPUs with AVX-512 VBMI and 256-level tables (merge_kernel_vbmi.cpp): the
// table reads are byte permutes of `planes` instead of gathers. Writes pixels x < done (a
// multiple of 64), the rest are the caller's (the Highway kernel's AVX-512 target calls it
// first and goes on from `done`). Only when merge_vbmi_usable(in).
constexpr size_t kMergeVbmiMaxFrames = 16;  // the levels of every frame of a block stay on the stack
bool merge_vbmi_usable(const MergeRowInput& in);
bool merge_vbmi_supported();  // the CPU has what merge_row_vbmi needs
MergeRowResult merge_row_vbmi(const MergeRowInput& in, float* out, uint8_t* flags, uint32_t* redo);
// Tests: false makes merge_vbmi_usable false, to test the AVX-512 gathers on a VBMI CPU too.
void set_merge_vbmi_for_test(bool allowed);

// The Highway target merge_row_simd dispatches to on this CPU (for logs and benchmarks).
const char* merge_simd_target();

}  // namespace lp::detail
