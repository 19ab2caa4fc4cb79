// The prefix sums of q2tree's prepare on a latlong or hemisphere map (sampling/q2tree.cpp):
// the map's pixels taken in HEALPix nested order, each weighed by its solid angle and
// direction, and summed in that order. Google Highway, compiled for every x86 target Highway
// knows and dispatched at run time (as sampling/row_sweep.h). Each sum is the scalar loop's
// chain of additions in its order (bit-identical: no fused multiply-add, sampling/CMakeLists.txt
// compiles the file with -ffp-contract=off). Internal to sampling/;
// tests/sampling/q2tree_sums_test.cpp compares every compiled target with a plain loop.
#pragma once

#include <cstddef>
#include <cstdint>

namespace lp::detail {

// Views into q2tree's cached binning of one layout and size (built once, see q2tree.cpp).
struct NestedSources {
  const uint32_t* source = nullptr;  // count: column u | row v << 16, in nested order
  const uint32_t* entry = nullptr;   // count: the prefix entry of the source's healpix pixel (pixel + 1)
  size_t count = 0;
  const double* row = nullptr;  // 4 per row: exact pixel solid angle, sin theta, cos theta, unused
  const double* col = nullptr;  // 2 per column: cos phi, sin phi
};

// Running sums s (six doubles, from +0) over the sources k = 0 .. count - 1 in order; after
// source k, prefix[6 entry[k] .. 6 entry[k] + 5] = s, so a healpix pixel's entry ends with
// the sums up to its last source. Entries of pixels without sources are not written. For
// source (u, v) of the width x height map, i = v width + u, p = rgb + 3 i, dw = row[4 v]:
//   (r, g, b) = valid && !valid[i] ? 0 : (double(p[0]) dw, double(p[1]) dw, double(p[2]) dw)
//   l = (0.2126 r + 0.7152 g) + 0.0722 b,  t = l row[4 v + 1]
//   s += (r, g, b, t col[2 u], t col[2 u + 1], l row[4 v + 2])
// An invalid pixel adds zeros, which leave every sum's bits as they were (a sum from +0 is
// never -0). Returns true when a valid pixel's r, g or b is negative.
bool q2tree_prefix_sums(const float* rgb, const uint8_t* valid, size_t width, size_t height,
                        const NestedSources& sources, double* prefix);

// The plain loop the kernel must equal bit for bit; also what runs on CPUs without AVX2.
bool q2tree_prefix_sums_scalar(const float* rgb, const uint8_t* valid, size_t width, size_t height,
                               const NestedSources& sources, double* prefix);

}  // namespace lp::detail
