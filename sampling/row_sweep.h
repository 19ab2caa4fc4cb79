// The row passes of the row-grid samplers' prepare (pharr, mediancut, hemigon) in Google
// Highway, compiled for every x86 target Highway knows and dispatched at run time (as
// hdr/merge_kernel.h): one row of packed RGB radiance -> its colours with invalid pixels
// zeroed and each pixel's luminance clamped at zero; rows' running channel sums in double;
// rows' running luminance sums (mediancut's summed-area table, hemigon's per-row sums).
// Each lane does the scalar loop's operations in its order (bit-identical: no fused
// multiply-add, sampling/CMakeLists.txt compiles this file with -ffp-contract=off).
// Internal to sampling/; tests/sampling/row_sweep_test.cpp compares every compiled target
// with the *_scalar loops.
#pragma once

#include <cstddef>
#include <cstdint>

namespace lp::detail {

// For x < width, with p = rgb + 3 * (reversed ? width - 1 - x : x) and ok = !valid || valid[..]:
//   colour[3x + c] = ok ? p[c] : 0
//   lum[x] = y > 0 ? y : 0 with y = (0.2126f r + 0.7152f g) + 0.0722f b of colour (std::max(0.0f, y))
// Returns true when a valid pixel's unclamped y is negative or NaN (hemigon rejects those).
// `valid` may be null (every pixel valid); it is indexed like rgb (reversed too). `colour`
// may be null: the luminances only, for a caller that reads the colours from rgb itself.
bool colour_and_luminance_row(const float* rgb, const uint8_t* valid, size_t width, bool reversed, float* colour,
                              float* lum);

// The plain loop the kernel must equal bit for bit.
bool colour_and_luminance_row_scalar(const float* rgb, const uint8_t* valid, size_t width, bool reversed,
                                     float* colour, float* lum);

// Adds `count` rows of packed RGB (`width` pixels each, e.g. colour rows from above) to
// running sums in double, each row's in pixel order: sums[6k + c] += every pixel's channel c
// of rows[k]; with `pairs`, even pixels go to sums[6k + c] and odd ones to sums[6k + 3 + c]
// (two partial sums per channel, as pharr keeps them). The caller sets the start values.
void add_channel_sums(const float* const* rows, size_t count, size_t width, bool pairs, double* sums);
void add_channel_sums_scalar(const float* const* rows, size_t count, size_t width, bool pairs, double* sums);

// `count` rows of a summed-area table of weighted luminance (each out[k] has width + 1
// entries): out[k][0] = 0 and out[k][x + 1] = prev[x + 1] + run, where prev is out[k - 1]
// (`above` for k = 0) and run = sum over i <= x of weight[k] * double(lum[k][i]), added in
// pixel order: the plain loop's values bit for bit.
void summed_area_rows(const float* const* lum, const double* weight, size_t count, size_t width, const double* above,
                      double* const* out);
void summed_area_rows_scalar(const float* const* lum, const double* weight, size_t count, size_t width,
                             const double* above, double* const* out);

// Each row's own running sums (each out[k] has width + 1 entries): out[k][0] = 0 and
// out[k][x + 1] = sum over i <= x of double(values[k][i]), added in pixel order.
void running_sums_rows(const float* const* values, size_t count, size_t width, double* const* out);
void running_sums_rows_scalar(const float* const* values, size_t count, size_t width, double* const* out);

// The Highway target colour_and_luminance_row dispatches to on this CPU.
const char* row_sweep_simd_target();

}  // namespace lp::detail
