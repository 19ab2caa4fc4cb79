// The sums of q2tree's prepare on a latlong or hemisphere map (sampling/q2tree.cpp), in two
// passes: each healpix pixel's sums of its source pixels (weighed by their solid angle and
// direction), the map read in row order; then the sums of every coarser quadtree node, four
// children at a time. All in float. The first pass runs in bands of rows on all cores, each
// band's runs into bins an earlier band also fills kept aside and added after, in band order,
// so that every bin's chain of additions is the row-order one whatever the thread count.
// Google Highway, compiled for every x86 target Highway knows and dispatched at run time (as
// sampling/row_sweep.h). Every sum is the plain loop's chain of operations in its order
// (bit-identical: no fused multiply-add, sampling/CMakeLists.txt compiles the file with
// -ffp-contract=off). Internal to sampling/; tests/sampling/q2tree_sums_test.cpp compares
// every compiled target with a plain loop.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace lp::detail {

// Set in a target entry on the first pixel of the first run of its healpix pixel (in row-major
// order): that run's sum replaces the bin's old content instead of adding to it.
inline constexpr uint32_t kQ2FirstRun = 1u << 31;
// Set in a target entry on the first pixel of a run whose healpix pixel an earlier band of rows
// also sums (RowSources::bands): the run's sum waits until the earlier bands are done.
inline constexpr uint32_t kQ2LaterBand = 1u << 30;
// The healpix pixel of a tagged target entry.
inline constexpr uint32_t kQ2Pixel = kQ2LaterBand - 1;

// q2tree's cached binning of one layout and size (built once, see q2tree.cpp).
struct RowSources {
  // Per map pixel, row-major: its healpix pixel (nested), | kQ2FirstRun and kQ2LaterBand as
  // above. A run is a maximal stretch of one row whose pixels have the same healpix pixel.
  const uint32_t* target = nullptr;
  const float* row = nullptr;  // 8 per row: 1, 1, 1, sin t, sin t, cos t, dw, 0 (dw: the pixel's solid angle)
  const float* col = nullptr;  // 8 per column: 1, 1, 1, cos p, sin p, 1, 0, 0
  const float* cos_phi = nullptr;  // per column: col[8 u + 3], col[8 u + 4] again, in a row
  const float* sin_phi = nullptr;
  // Bands of rows summed in parallel: band b is rows [band_rows[b], band_rows[b + 1]) and has
  // band_later_runs[b] runs tagged kQ2LaterBand. bands = 0 or 1: the map is one band, untagged.
  const uint32_t* band_rows = nullptr;
  const uint32_t* band_later_runs = nullptr;
  size_t bands = 0;
};

// A run kept aside by its band (kQ2LaterBand): its sum and healpix pixel.
struct alignas(32) LaterRun {
  float sum[8];
  uint32_t pixel;
};

// The tags of RowSources::target: given each pixel's healpix pixel (< kQ2LaterBand) in
// `target`, sets kQ2FirstRun and, for `bands` bands of equal rows, kQ2LaterBand, and returns
// band_rows and band_later_runs for them.
struct RunTags {
  std::vector<uint32_t> band_rows, band_later_runs;
};
RunTags q2tree_tag_runs(uint32_t* target, size_t width, size_t height, size_t bands);

// Each healpix pixel's 8 floats in `bins` (8 a pixel, 32-byte aligned): for each run in
// row-major order, its sum s (from +0, over its valid pixels in order) is added to the bin,
// bin = (first run ? +0 : bin) + s, lane by lane. For pixel i = v width + u, p = rgb + 3 i,
// R = row + 8 v, C = col + 8 u, dw = R[6]:
//   (r, g, b) = (p[0] dw, p[1] dw, p[2] dw),  l = (0.2126f r + 0.7152f g) + (0.0722f b + 0)
//   s[k] += (r, g, b, l, l, l, l, l)[k] (R[k] C[k])
// (lanes 0-2 multiply by 1, lanes 6 and 7 by 0; the "+ 0" only turns a -0 into +0, as the
// kernel's lane sums do, and a sum from +0 never changes its bits by adding a zero of either
// sign). Bins of healpix pixels without sources are not touched. Returns true when a valid
// pixel's r, g or b is negative. With bands, they run in parallel (TBB) and give the same bits.
bool q2tree_bin_sums(const float* rgb, const uint8_t* valid, size_t width, size_t height, const RowSources& sources,
                     float* bins);

// The plain loop the kernel must equal bit for bit; also what runs on CPUs without AVX2.
bool q2tree_bin_sums_scalar(const float* rgb, const uint8_t* valid, size_t width, size_t height,
                            const RowSources& sources, float* bins);

// One quadtree level up: parent[8 p + k] = (child[32 p + k] + child[32 p + 8 + k]) +
// (child[32 p + 16 + k] + child[32 p + 24 + k]) for p < parents, k < 8 (both 32-byte aligned).
void q2tree_quad_sums(const float* child, size_t parents, float* parent);
// Three levels up at once, the same sums: for g < groups, q2tree_quad_sums over the 64
// children from child + 512 g into level1's 16 parents from 128 g, those into level2's 4 from
// 32 g, and those into level3[8 g..8 g + 8).
void q2tree_quad_sums3(const float* child, size_t groups, float* level1, float* level2, float* level3);
void q2tree_quad_sums_scalar(const float* child, size_t parents, float* parent);

}  // namespace lp::detail
