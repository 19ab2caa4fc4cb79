// The row kernel of sampling/row_sweep.h. Compiled once per target: hwy/foreach_target.h
// includes this file again for SSSE3, SSE4, AVX2 and AVX-512 (and the scalar fallback), and
// HWY_DYNAMIC_DISPATCH picks the best one the CPU has at the first call; the build stays
// baseline x86-64.
//
// Why: the samplers' prepare did this pixel by pixel, interleaved with their running sums,
// and the scalar loop (three loads, a copy, the luminance, a clamp per pixel) cost as much as
// the sums themselves. Here N pixels at a time are deinterleaved, masked, weighed and stored
// (N = 16 with AVX-512), and the serial sums read the results from cache.
//
// Bit-identical to the scalar loop: every lane does its operations in its order (two
// products added, then the third; no fused multiply-add: -ffp-contract=off, and Highway's
// Mul/Add are separate instructions); the clamp keeps std::max(0.0f, y)'s answer for NaN
// and -0 (zero).

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "sampling/row_sweep.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep

#include <hwy/highway.h>

#include <algorithm>

#include "core/envmap.h"
#include "sampling/row_sweep.h"

HWY_BEFORE_NAMESPACE();
namespace lp::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// kCopy false: the luminances only (colour is null).
template <bool kCopy>
HWY_INLINE bool ColourAndLuminanceRowT(const float* rgb, const uint8_t* valid, size_t width, bool reversed,
                                       float* colour, float* lum) {
  // At most 8 lanes: with AVX-512, Highway 1.0's 16-lane (de)interleave costs more
  // permutes than it saves (measured: 0.60 ns a pixel against 0.37 with 8 lanes).
  const hn::CappedTag<float, 8> df;
  const hn::RebindToUnsigned<decltype(df)> du32;
  const hn::Rebind<uint8_t, decltype(df)> du8;
  using VF = hn::Vec<decltype(df)>;
  const size_t N = hn::Lanes(df);
  const VF kr = hn::Set(df, 0.2126f), kg = hn::Set(df, 0.7152f), kb = hn::Set(df, 0.0722f);
  const VF zero = hn::Zero(df);
  auto bad = hn::Zero(df);  // lanes set where a pixel's luminance was negative or NaN
  size_t x = 0;
  for (; x + N <= width; x += N) {
    // Source pixels [s, s + N): the same as x unless reversed.
    const size_t s = reversed ? width - x - N : x;
    VF r, g, b;
    hn::LoadInterleaved3(df, rgb + 3 * s, r, g, b);
    if (reversed) {
      r = hn::Reverse(df, r);
      g = hn::Reverse(df, g);
      b = hn::Reverse(df, b);
    }
    if (valid) {
      auto v = hn::PromoteTo(du32, hn::LoadU(du8, valid + s));
      if (reversed) v = hn::Reverse(du32, v);
      const auto ok = hn::RebindMask(df, hn::Ne(v, hn::Zero(du32)));
      r = hn::IfThenElseZero(ok, r);
      g = hn::IfThenElseZero(ok, g);
      b = hn::IfThenElseZero(ok, b);
    }
    const VF y = hn::Add(hn::Add(hn::Mul(kr, r), hn::Mul(kg, g)), hn::Mul(kb, b));
    bad = hn::Or(bad, hn::VecFromMask(df, hn::Not(hn::Ge(y, zero))));
    if (kCopy) {
      if (valid || reversed) {
        hn::StoreInterleaved3(r, g, b, df, colour + 3 * x);
      } else {  // a plain copy: three loads and stores instead of re-interleaving
        for (size_t v = 0; v < 3; ++v) hn::StoreU(hn::LoadU(df, rgb + 3 * s + v * N), df, colour + 3 * x + v * N);
      }
    }
    hn::StoreU(hn::IfThenElseZero(hn::Gt(y, zero), y), df, lum + x);
  }
  bool any_bad = !hn::AllFalse(df, hn::MaskFromVec(bad));
  if (x < width) {  // the last pixels, fewer than a vector
    const size_t rest = width - x;
    const float* src = reversed ? rgb : rgb + 3 * x;
    const uint8_t* ok = valid ? (reversed ? valid : valid + x) : nullptr;
    any_bad |= colour_and_luminance_row_scalar(src, ok, rest, reversed, kCopy ? colour + 3 * x : nullptr, lum + x);
  }
  return any_bad;
}

bool ColourAndLuminanceRow(const float* rgb, const uint8_t* valid, size_t width, bool reversed, float* colour,
                           float* lum) {
  return colour ? ColourAndLuminanceRowT<true>(rgb, valid, width, reversed, colour, lum)
                : ColourAndLuminanceRowT<false>(rgb, valid, width, reversed, nullptr, lum);
}

// Each row's running channel sums, rows in lockstep so that their chains overlap, in
// double vectors whose lanes are whole chains (a lane never takes another chain's addend, so
// each sum is the scalar loop's, rounding for rounding). The float -> double conversions
// bound this loop, so the widest vectors that fit a pixel (or a pair) are used.
template <size_t K>
HWY_INLINE void ChannelSumsK(const float* const* rows, size_t width, bool pairs, double* sums) {
#if HWY_TARGET == HWY_SCALAR
  add_channel_sums_scalar(rows, K, width, pairs, sums);
#elif HWY_TARGET <= HWY_AVX2  // 256-bit vectors: four doubles from four floats
  const hn::Full256<double> d4;
  const hn::Full128<double> d2;
  const hn::Full128<float> f4;
  const hn::Full64<float> f2;
  size_t x = 0;
  if (pairs) {  // lanes (s0 r, s0 g, s0 b, s1 r) and (s1 g, s1 b): a pixel pair fills them
    hn::Vec<decltype(d4)> a[K];
    hn::Vec<decltype(d2)> b[K];
    for (size_t k = 0; k < K; ++k) {
      a[k] = hn::LoadU(d4, sums + 6 * k);
      b[k] = hn::LoadU(d2, sums + 6 * k + 4);
    }
    for (; x + 1 < width; x += 2)
      for (size_t k = 0; k < K; ++k) {
        const float* p = rows[k] + 3 * x;
        a[k] = hn::Add(a[k], hn::PromoteTo(d4, hn::LoadU(f4, p)));
        b[k] = hn::Add(b[k], hn::PromoteTo(d2, hn::LoadU(f2, p + 4)));
      }
    for (size_t k = 0; k < K; ++k) {
      hn::StoreU(a[k], d4, sums + 6 * k);
      hn::StoreU(b[k], d2, sums + 6 * k + 4);
    }
  }
#if HWY_TARGET <= HWY_AVX3
  else if (K % 2 == 0) {  // 512-bit: two rows' (r, g, b, -) a vector, one conversion for both
    // (the conversions bound the loop: 1024x512 rows, eight at a time, 147 -> 116 us)
    const hn::Full512<double> d8;
    const hn::Full256<float> f8;
    hn::Vec<decltype(d8)> a[K / 2];
    HWY_ALIGN double start[4 * K];
    for (size_t k = 0; k < K; ++k) {
      for (int ch = 0; ch < 3; ++ch) start[4 * k + ch] = sums[6 * k + ch];
      start[4 * k + 3] = 0;
    }
    for (size_t k = 0; k < K / 2; ++k) a[k] = hn::Load(d8, start + 8 * k);
    for (; x + 1 < width; ++x)
      for (size_t k = 0; k < K / 2; ++k) {
        const auto two = hn::Combine(f8, hn::LoadU(f4, rows[2 * k + 1] + 3 * x), hn::LoadU(f4, rows[2 * k] + 3 * x));
        a[k] = hn::Add(a[k], hn::PromoteTo(d8, two));
      }
    for (size_t k = 0; k < K / 2; ++k) hn::Store(a[k], d8, start + 8 * k);
    for (size_t k = 0; k < K; ++k)
      for (int ch = 0; ch < 3; ++ch) sums[6 * k + ch] = start[4 * k + ch];
  }
#endif
  else {  // lanes (r, g, b, -): the fourth takes the next pixel's red and is dropped
    hn::Vec<decltype(d4)> a[K];
    HWY_ALIGN double start[4 * K];
    for (size_t k = 0; k < K; ++k) {
      for (int ch = 0; ch < 3; ++ch) start[4 * k + ch] = sums[6 * k + ch];
      start[4 * k + 3] = 0;
      a[k] = hn::Load(d4, start + 4 * k);
    }
    for (; x + 1 < width; ++x)  // the last pixel's 4-float load would read past the row
      for (size_t k = 0; k < K; ++k) a[k] = hn::Add(a[k], hn::PromoteTo(d4, hn::LoadU(f4, rows[k] + 3 * x)));
    for (size_t k = 0; k < K; ++k) {
      hn::Store(a[k], d4, start + 4 * k);
      for (int ch = 0; ch < 3; ++ch) sums[6 * k + ch] = start[4 * k + ch];
    }
  }
  if (x < width)  // the last pixel (odd in a pair sweep: it goes to s0)
    for (size_t k = 0; k < K; ++k)
      for (int ch = 0; ch < 3; ++ch) sums[6 * k + ch] += rows[k][3 * x + ch];
#else  // 128-bit vectors: two doubles from two floats
  const hn::Full128<double> dd;
  const hn::Full64<float> d2;
  using VD = hn::Vec<decltype(dd)>;
  auto two = [&](const float* p) { return hn::PromoteTo(dd, hn::LoadU(d2, p)); };
  VD a[K], b[K], c[K];
  double blue[K];
  for (size_t k = 0; k < K; ++k) {
    a[k] = hn::LoadU(dd, sums + 6 * k);
    b[k] = hn::LoadU(dd, sums + 6 * k + 2);
    c[k] = hn::LoadU(dd, sums + 6 * k + 4);
    blue[k] = sums[6 * k + 2];
  }
  size_t x = 0;
  if (pairs) {  // lanes (s0 r, s0 g), (s0 b, s1 r), (s1 g, s1 b): a pixel pair fills them
    for (; x + 1 < width; x += 2)
      for (size_t k = 0; k < K; ++k) {
        const float* p = rows[k] + 3 * x;
        a[k] = hn::Add(a[k], two(p));
        b[k] = hn::Add(b[k], two(p + 2));
        c[k] = hn::Add(c[k], two(p + 4));
      }
    for (size_t k = 0; k < K; ++k) {
      hn::StoreU(a[k], dd, sums + 6 * k);
      hn::StoreU(b[k], dd, sums + 6 * k + 2);
      hn::StoreU(c[k], dd, sums + 6 * k + 4);
    }
  } else {  // lanes (r, g) and blue on its own
    for (; x + 1 < width; ++x)  // the last pixel's (r, g) load is done below with it
      for (size_t k = 0; k < K; ++k) {
        const float* p = rows[k] + 3 * x;
        a[k] = hn::Add(a[k], two(p));
        blue[k] += double(p[2]);
      }
    for (size_t k = 0; k < K; ++k) {
      hn::StoreU(a[k], dd, sums + 6 * k);
      sums[6 * k + 2] = blue[k];
    }
  }
  if (x < width)  // the last pixel (odd in a pair sweep: it goes to s0)
    for (size_t k = 0; k < K; ++k)
      for (int ch = 0; ch < 3; ++ch) sums[6 * k + ch] += rows[k][3 * x + ch];
#endif
}

void AddChannelSums(const float* const* rows, size_t count, size_t width, bool pairs, double* sums) {
#if HWY_TARGET <= HWY_AVX2
  // Single sums keep one chain a row: eight rows keep more adds in flight than four and
  // still fit the registers (1024x512 rows from cache, AVX-512: 126 -> 118 us). Pair sums
  // have two chains a row already.
  if (!pairs)
    for (; count >= 8; count -= 8, rows += 8, sums += 48) ChannelSumsK<8>(rows, width, pairs, sums);
#endif
  for (; count >= 4; count -= 4, rows += 4, sums += 24) ChannelSumsK<4>(rows, width, pairs, sums);
  for (; count > 0; --count, ++rows, sums += 6) ChannelSumsK<1>(rows, width, pairs, sums);
}

#if HWY_TARGET != HWY_SCALAR && HWY_TARGET <= HWY_AVX2
// A 4 x 4 block of doubles transposed: v[i] lane j <-> v[j] lane i.
HWY_INLINE void Transpose4(hn::Full256<double> d, hn::Vec<hn::Full256<double>>* v) {
  const auto t0 = hn::InterleaveLower(d, v[0], v[1]);  // a0 b0 a2 b2
  const auto t1 = hn::InterleaveUpper(d, v[0], v[1]);  // a1 b1 a3 b3
  const auto t2 = hn::InterleaveLower(d, v[2], v[3]);  // c0 d0 c2 d2
  const auto t3 = hn::InterleaveUpper(d, v[2], v[3]);  // c1 d1 c3 d3
  v[0] = hn::ConcatLowerLower(d, t2, t0);
  v[1] = hn::ConcatLowerLower(d, t3, t1);
  v[2] = hn::ConcatUpperUpper(d, t2, t0);
  v[3] = hn::ConcatUpperUpper(d, t3, t1);
}

// G groups of four rows, four columns at a time. In a group the running sums along the rows
// are one vector whose lanes are the four rows (each lane the scalar chain: the four
// columns' values added one after the other), the sums down the columns (kTable) are
// vectors whose lanes are columns; a 4 x 4 transpose turns one into the other. Stores are
// whole vectors (the plain loop stored one double per entry and was bound by it), and G
// groups keep G chains of adds in flight. kTable: the summed-area rows of
// summed_area_rows (weighted values, each row added to the one above); otherwise each
// row's own running sums of its plain values (running_sums_rows).
template <size_t G, bool kTable>
void TransposedRowSums(const float* const* lum, const double* weight, size_t width, const double* above,
                       double* const* out) {
  const hn::Full256<double> d;
  const hn::Full128<float> f;
  using V = hn::Vec<decltype(d)>;
  V w[G], run[G];
  for (size_t g = 0; g < G; ++g) {
    if (kTable) w[g] = hn::LoadU(d, weight + 4 * g);
    run[g] = hn::Zero(d);
  }
  size_t x = 0;
  for (; x + 4 <= width; x += 4) {
    V down;
    if (kTable) down = hn::LoadU(d, above + 1 + x);
    for (size_t g = 0; g < G; ++g) {
      V v[4];
      for (size_t i = 0; i < 4; ++i) v[i] = hn::PromoteTo(d, hn::LoadU(f, lum[4 * g + i] + x));
      Transpose4(d, v);  // v[j]: column x + j, lanes = rows
      for (size_t j = 0; j < 4; ++j) {
        run[g] = hn::Add(run[g], kTable ? hn::Mul(w[g], v[j]) : v[j]);
        v[j] = run[g];
      }
      Transpose4(d, v);  // v[i]: row 4g + i, lanes = columns
      for (size_t i = 0; i < 4; ++i) {
        if (kTable) v[i] = down = hn::Add(down, v[i]);
        hn::StoreU(v[i], d, out[4 * g + i] + 1 + x);
      }
    }
  }
  // The last columns (fewer than four) in the plain loop's order, each row's sum carried on.
  HWY_ALIGN double carried[4 * G];
  for (size_t g = 0; g < G; ++g) hn::Store(run[g], d, carried + 4 * g);
  for (size_t k = 0; k < 4 * G; ++k) {
    const double* a = k ? out[k - 1] : above;
    double sum = carried[k];
    for (size_t c = x; c < width; ++c) {
      if (kTable) {
        sum += weight[k] * double(lum[k][c]);
        out[k][c + 1] = a[c + 1] + sum;
      } else {
        out[k][c + 1] = sum += double(lum[k][c]);
      }
    }
    out[k][0] = 0;
  }
}
#endif

void SummedAreaRows(const float* const* lum, const double* weight, size_t count, size_t width, const double* above,
                    double* const* out) {
  size_t k = 0;
#if HWY_TARGET != HWY_SCALAR && HWY_TARGET <= HWY_AVX2  // 256-bit vectors: four doubles
  for (; k + 8 <= count; k += 8)
    TransposedRowSums<2, true>(lum + k, weight + k, width, k ? out[k - 1] : above, out + k);
  for (; k + 4 <= count; k += 4)
    TransposedRowSums<1, true>(lum + k, weight + k, width, k ? out[k - 1] : above, out + k);
#endif
  if (k < count) summed_area_rows_scalar(lum + k, weight + k, count - k, width, k ? out[k - 1] : above, out + k);
}

void RunningSumsRows(const float* const* lum, size_t count, size_t width, double* const* out) {
  size_t k = 0;
#if HWY_TARGET != HWY_SCALAR && HWY_TARGET <= HWY_AVX2
  for (; k + 8 <= count; k += 8) TransposedRowSums<2, false>(lum + k, nullptr, width, nullptr, out + k);
  for (; k + 4 <= count; k += 4) TransposedRowSums<1, false>(lum + k, nullptr, width, nullptr, out + k);
#endif
  if (k < count) running_sums_rows_scalar(lum + k, count - k, width, out + k);
}

const char* RowSweepTargetName() { return hwy::TargetName(HWY_TARGET); }

}  // namespace HWY_NAMESPACE
}  // namespace lp::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace lp::detail {

HWY_EXPORT(ColourAndLuminanceRow);
HWY_EXPORT(RowSweepTargetName);
HWY_EXPORT(AddChannelSums);
HWY_EXPORT(SummedAreaRows);
HWY_EXPORT(RunningSumsRows);

void running_sums_rows(const float* const* values, size_t count, size_t width, double* const* out) {
  HWY_DYNAMIC_DISPATCH(RunningSumsRows)(values, count, width, out);
}

void running_sums_rows_scalar(const float* const* values, size_t count, size_t width, double* const* out) {
  for (size_t k = 0; k < count; ++k) {
    double sum = 0;
    out[k][0] = 0;
    for (size_t x = 0; x < width; ++x) out[k][x + 1] = sum += double(values[k][x]);
  }
}

void summed_area_rows(const float* const* lum, const double* weight, size_t count, size_t width, const double* above,
                      double* const* out) {
  HWY_DYNAMIC_DISPATCH(SummedAreaRows)(lum, weight, count, width, above, out);
}

void summed_area_rows_scalar(const float* const* lum, const double* weight, size_t count, size_t width,
                             const double* above, double* const* out) {
  for (size_t k = 0; k < count; ++k) {
    const double* a = k ? out[k - 1] : above;
    double run = 0;
    out[k][0] = 0;
    for (size_t x = 0; x < width; ++x) {
      run += weight[k] * double(lum[k][x]);
      out[k][x + 1] = a[x + 1] + run;
    }
  }
}

void add_channel_sums(const float* const* rows, size_t count, size_t width, bool pairs, double* sums) {
  HWY_DYNAMIC_DISPATCH(AddChannelSums)(rows, count, width, pairs, sums);
}

void add_channel_sums_scalar(const float* const* rows, size_t count, size_t width, bool pairs, double* sums) {
  for (size_t k = 0; k < count; ++k) {
    double* s = sums + 6 * k;
    for (size_t x = 0; x < width; ++x) {
      double* t = pairs && (x & 1) ? s + 3 : s;
      for (int c = 0; c < 3; ++c) t[c] += rows[k][3 * x + c];
    }
  }
}

bool colour_and_luminance_row(const float* rgb, const uint8_t* valid, size_t width, bool reversed, float* colour,
                              float* lum) {
  return HWY_DYNAMIC_DISPATCH(ColourAndLuminanceRow)(rgb, valid, width, reversed, colour, lum);
}

bool colour_and_luminance_row_scalar(const float* rgb, const uint8_t* valid, size_t width, bool reversed,
                                     float* colour, float* lum) {
  bool bad = false;
  for (size_t x = 0; x < width; ++x) {
    const size_t s = reversed ? width - 1 - x : x;
    float a[3] = {rgb[3 * s], rgb[3 * s + 1], rgb[3 * s + 2]};
    if (valid && !valid[s]) a[0] = a[1] = a[2] = 0;
    if (colour)
      for (int c = 0; c < 3; ++c) colour[3 * x + c] = a[c];
    const float y = luminance(a[0], a[1], a[2]);
    bad |= !(y >= 0);
    lum[x] = std::max(0.0f, y);
  }
  return bad;
}

const char* row_sweep_simd_target() { return HWY_DYNAMIC_DISPATCH(RowSweepTargetName)(); }

}  // namespace lp::detail
#endif  // HWY_ONCE
