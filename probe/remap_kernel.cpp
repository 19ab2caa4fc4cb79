// The unwrap's bilinear gather in Google Highway (see remap_kernel.h). Compiled once per
// target through hwy/foreach_target.h (SSSE3, SSE4, AVX2, AVX-512 and the scalar fallback),
// the best one the CPU has chosen at the first call; the build stays baseline x86-64.
//
// Why it is faster than the scalar loop (probe/remap.cpp): per output pixel the scalar loop
// decodes its tap, forms four weights and does twelve loads, twelve multiplies and nine adds
// one float at a time. Here the taps and weights of N pixels (16 with AVX-512) are decoded
// in full vectors, and each pixel's 2 x 2 footprint is four 128-bit loads with the three
// channels in lanes: four multiplies and three adds. Gathers (twelve per N pixels) were
// tried first and were slower than the scalar loop on this project's AMD EPYC (AVX-512 4.96
// ms, AVX2 9.69 ms against 3.26 ms on one thread): its gathers cost more than the loads they
// replace. Now, one thread, the bench's 1280x960 -> 1024x512 unwrap (best of 9): scalar loop
// 2.96 ms; this kernel AVX-512 1.67 ms, AVX2 1.58, SSE4 1.56 (two threads: docs/performance.md).
//
// Bit-identical to the scalar loop: every lane does its operations in its order (fractions
// = float(code) * 2^-15; w00 = (1 - fx)(1 - fy) ...; value = ((w00 p00 + w10 p10) + w01 p01)
// + w11 p11), with no fused multiply-add (probe/CMakeLists.txt compiles this file and
// remap.cpp with -ffp-contract=off).

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "probe/remap_kernel.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep

#include <hwy/highway.h>

#include "probe/remap_kernel.h"

HWY_BEFORE_NAMESPACE();
namespace lp::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

size_t RemapRun(const float* src, ptrdiff_t src_width, const CompiledRemap::Tap* taps, size_t count, float* out) {
#if HWY_TARGET == HWY_SCALAR
  return 0;  // one lane: nothing to gain over the caller's scalar loop
#else
  static_assert(sizeof(CompiledRemap::Tap) == 8, "a tap is two int32 lanes: index, fx | fy << 16");
  const hn::ScalableTag<float> df;
  const hn::RebindToSigned<decltype(df)> di;
  const hn::RebindToUnsigned<decltype(df)> du;
  using VF = hn::Vec<decltype(df)>;
  using VI = hn::Vec<decltype(di)>;
  const hn::FixedTag<float, 4> d4;  // one output pixel: its three channels and one spare lane
  const size_t N = hn::Lanes(df);
  const VF unit = hn::Set(df, 1.0f / CompiledRemap::kFractionScale);
  const VF one = hn::Set(df, 1.0f);
  const VI low16 = hn::Set(di, 0xFFFF);
  const ptrdiff_t row = 3 * src_width;  // floats from a pixel to the one below
  const int32_t* words = reinterpret_cast<const int32_t*>(taps);
  HWY_ALIGN float weight[4][hn::MaxLanes(df)];
  HWY_ALIGN int32_t first[hn::MaxLanes(df)];
  HWY_ALIGN float last_pixel[4];
  for (size_t r = 0; r < count / N; ++r) {
    // The weights of N pixels at once.
    VI index, fractions;
    hn::LoadInterleaved2(di, words + 2 * N * r, index, fractions);
    const VF fx = hn::Mul(hn::ConvertTo(df, hn::And(fractions, low16)), unit);
    const VF fy = hn::Mul(hn::ConvertTo(df, hn::BitCast(di, hn::ShiftRight<16>(hn::BitCast(du, fractions)))), unit);
    const VF gx = hn::Sub(one, fx), gy = hn::Sub(one, fy);
    hn::Store(hn::Mul(gx, gy), df, weight[0]);
    hn::Store(hn::Mul(fx, gy), df, weight[1]);
    hn::Store(hn::Mul(gx, fy), df, weight[2]);
    hn::Store(hn::Mul(fx, fy), df, weight[3]);
    hn::Store(index, di, first);
    // Then each pixel's 2 x 2 footprint, channels in lanes: four loads instead of twelve.
    for (size_t j = 0; j < N; ++j) {
      const size_t i = N * r + j;
      auto value = hn::Zero(d4);
      if (first[j] >= 0) {
        const float* p = src + 3 * ptrdiff_t(first[j]);
        const auto p00 = hn::LoadU(d4, p), p10 = hn::LoadU(d4, p + 3), p01 = hn::LoadU(d4, p + row);
        // p + row + 3 would read one float past the image at its last pixel: load from + 2, shift.
        const auto p11 = hn::ShiftRightLanes<1>(d4, hn::LoadU(d4, p + row + 2));
        value = hn::Add(hn::Mul(hn::Set(d4, weight[0][j]), p00), hn::Mul(hn::Set(d4, weight[1][j]), p10));
        value = hn::Add(value, hn::Mul(hn::Set(d4, weight[2][j]), p01));
        value = hn::Add(value, hn::Mul(hn::Set(d4, weight[3][j]), p11));
      }
      if (i + 1 < count) {
        hn::StoreU(value, d4, out + 3 * i);  // the spare lane is the next pixel's, written next
      } else {
        hn::Store(value, d4, last_pixel);  // the run's last pixel: its three floats only
        for (int c = 0; c < 3; ++c) out[3 * i + size_t(c)] = last_pixel[c];
      }
    }
  }
  return count / N * N;
#endif
}

const char* RemapTargetName() { return hwy::TargetName(HWY_TARGET); }

}  // namespace HWY_NAMESPACE
}  // namespace lp::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace lp::detail {

HWY_EXPORT(RemapRun);
HWY_EXPORT(RemapTargetName);

size_t remap_run_simd(const float* src, ptrdiff_t src_width, const CompiledRemap::Tap* taps, size_t count,
                      float* out) {
  return HWY_DYNAMIC_DISPATCH(RemapRun)(src, src_width, taps, count, out);
}

const char* remap_simd_target() { return HWY_DYNAMIC_DISPATCH(RemapTargetName)(); }

}  // namespace lp::detail
#endif  // HWY_ONCE
