// The kernel of sampling/q2tree_sums.h. Compiled once per target: hwy/foreach_target.h
// includes this file again for SSSE3, SSE4, AVX2 and AVX-512 (and the scalar fallback), and
// HWY_DYNAMIC_DISPATCH picks the best one the CPU has at the first call.
//
// Why: q2tree's prepare walked the sources pixel by pixel in scalar code, ~45 instructions a
// source; it took 5.7x a plain read of the map. The running sums are six chains of one
// addition a source, which no reordering may change, so the sources stay one at a time, but
// each source's values are built in two vectors laid out as the sums are, (r, g, b, x) and
// (y, z): one 16-byte load of the pixel, one multiply for its three channels, the luminance
// and the direction in a few shuffles, and two vector additions to the running sums. With
// AVX2 and AVX-512 about 0.8x the old loop's time in the benchmark, and 0.86-0.9x the plain
// loop below (whose sums stay in registers) in a micro-benchmark (docs/sampling.md). Gathering eight
// sources at a time into lanes was tried first and was slower than the scalar loop: eight
// gathered elements a source (three channels, five geometry factors), and this CPU's gathers
// fetch about one element a cycle.
//
// Bit-identical to the scalar loop: the same operations on the same values in the same order
// (the luminance's two products added, then the third; no fused multiply-add: -ffp-contract=off,
// and Highway's Mul/Add are separate instructions), and each vector lane of the sums is one chain.

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "sampling/q2tree_sums.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep

#include <hwy/cache_control.h>
#include <hwy/highway.h>

#include <algorithm>

#include "sampling/q2tree_sums.h"

HWY_BEFORE_NAMESPACE();
namespace lp::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

bool Q2treePrefixSums(const float* rgb, const uint8_t* valid, size_t width, size_t height, const NestedSources& s,
                      double* prefix) {
#if HWY_TARGET <= HWY_AVX2
  const hn::Full256<double> d4;
  const hn::Full128<double> d2;
  const hn::Full128<float> f4;
  HWY_ALIGN static constexpr double kLuminance[4] = {0.2126, 0.7152, 0.0722, 0.0};
  const auto weights = hn::Load(d4, kLuminance);
  const auto zero = hn::Zero(d4);
  auto sum4 = zero;            // r, g, b, x
  auto sum2 = hn::Zero(d2);    // y, z
  auto negative = zero;        // lanes 0..2: a channel was negative
  const uint32_t* source = s.source;
  const uint32_t* entry = s.entry;
  const double* rows = s.row;
  const double* cols = s.col;
  const size_t count = s.count, last_pixel = width * height - 1;
  // The nested order jumps between rows, out of the hardware prefetcher's sight: ask for the
  // pixel kAhead sources on (without, most of the time went to the map's cache misses).
  constexpr size_t kAhead = 32;
  for (size_t k = 0; k < count; ++k) {
    if (k + kAhead < count) {
      const uint32_t q = source[k + kAhead];
      hwy::Prefetch(rgb + 3 * (size_t(q >> 16) * width + (q & 0xFFFF)));
    }
    const uint32_t q = source[k];
    const size_t u = q & 0xFFFF, v = q >> 16, i = v * width + u;
    const double* row = rows + 4 * v;
    // (r, g, b, next pixel's r): the fourth float is read only where it exists.
    hn::Vec<decltype(f4)> p4;
    if (HWY_LIKELY(i != last_pixel)) {
      p4 = hn::LoadU(f4, rgb + 3 * i);
    } else {
      HWY_ALIGN float last[4] = {rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2], 0.0f};
      p4 = hn::Load(f4, last);
    }
    if (valid && !valid[i]) p4 = hn::Zero(f4);
    const auto c = hn::Mul(hn::PromoteTo(d4, p4), hn::Set(d4, row[0]));  // r, g, b, -
    negative = hn::Or(negative, hn::VecFromMask(d4, hn::Lt(c, zero)));
    const auto m = hn::Mul(c, weights);
    const auto m01 = hn::LowerHalf(d2, m);
    const auto l = hn::Add(hn::Add(m01, hn::Shuffle01(m01)), hn::DupEven(hn::UpperHalf(d2, m)));  // l, l
    const auto t = hn::Mul(l, hn::Set(d2, row[1]));
    const auto xy = hn::Mul(t, hn::LoadU(d2, cols + 2 * u));
    const auto z = hn::Mul(l, hn::Set(d2, row[2]));
    const auto bx = hn::InterleaveLower(d2, hn::UpperHalf(d2, c), xy);
    sum4 = hn::Add(sum4, hn::Combine(d4, bx, hn::LowerHalf(d2, c)));
    sum2 = hn::Add(sum2, hn::InterleaveUpper(d2, xy, z));
    double* out = prefix + 6 * size_t(entry[k]);
    hn::StoreU(sum4, d4, out);
    hn::StoreU(sum2, d2, out + 4);
  }
  HWY_ALIGN double flags[4];
  hn::Store(negative, d4, flags);
  return flags[0] != 0 || flags[1] != 0 || flags[2] != 0;
#else  // 128-bit vectors would split every source in three: the plain loop
  return q2tree_prefix_sums_scalar(rgb, valid, width, height, s, prefix);
#endif
}

}  // namespace HWY_NAMESPACE
}  // namespace lp::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace lp::detail {

HWY_EXPORT(Q2treePrefixSums);

bool q2tree_prefix_sums(const float* rgb, const uint8_t* valid, size_t width, size_t height,
                        const NestedSources& sources, double* prefix) {
  return HWY_DYNAMIC_DISPATCH(Q2treePrefixSums)(rgb, valid, width, height, sources, prefix);
}

bool q2tree_prefix_sums_scalar(const float* rgb, const uint8_t* valid, size_t width, size_t, const NestedSources& s,
                               double* prefix) {
  // Six named running sums, so that the compiler keeps them in registers (an array of
  // them went through memory: 2.5x slower).
  double sr = 0, sg = 0, sb = 0, sx = 0, sy = 0, sz = 0;
  bool negative = false;
  for (size_t k = 0; k < s.count; ++k) {
    if (k + 32 < s.count) {  // as in the kernel
      const uint32_t q = s.source[k + 32];
      __builtin_prefetch(rgb + 3 * (size_t(q >> 16) * width + (q & 0xFFFF)));
    }
    const size_t u = s.source[k] & 0xFFFF, v = s.source[k] >> 16, i = v * width + u;
    const double* row = s.row + 4 * v;
    const bool ok = !valid || valid[i];
    const double dw = row[0];
    const double r = ok ? double(rgb[3 * i]) * dw : 0.0;
    const double g = ok ? double(rgb[3 * i + 1]) * dw : 0.0;
    const double b = ok ? double(rgb[3 * i + 2]) * dw : 0.0;
    negative |= (r < 0) | (g < 0) | (b < 0);
    const double l = 0.2126 * r + 0.7152 * g + 0.0722 * b;
    const double t = l * row[1];
    sr += r, sg += g, sb += b;
    sx += t * s.col[2 * u], sy += t * s.col[2 * u + 1], sz += l * row[2];
    double* out = prefix + 6 * size_t(s.entry[k]);
    out[0] = sr, out[1] = sg, out[2] = sb, out[3] = sx, out[4] = sy, out[5] = sz;
  }
  return negative;
}

}  // namespace lp::detail
#endif  // HWY_ONCE
