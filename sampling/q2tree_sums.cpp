// The kernels of sampling/q2tree_sums.h. Compiled once per target: hwy/foreach_target.h
// includes this file again for SSSE3, SSE4, AVX2 and AVX-512 (and the scalar fallback), and
// HWY_DYNAMIC_DISPATCH picks the best one the CPU has at the first call.
//
// Why in row order: the nested order jumps between rows, so q2tree's earlier pass gathered
// every pixel and kept one double running sum (a 48-byte prefix entry per healpix pixel), and
// it could not be cheap: gathering the pixels in nested order and adding them, with no other
// work, already takes 1.4-1.7x a plain read of the map here, and the whole pass took
// 4.8-5.3x (about 40 instructions and 6 cycles a source pixel). Read in row order, the map
// streams and a row's geometry is loaded once. A healpix pixel meets a row in a run of
// adjacent pixels (2.2 on average at 1024 x 512), summed in a register and added to the bin
// once: one 32-byte load and store a run. A branch on the run's end mispredicts often, but
// the branch-free form (storing every pixel's running sums) measured slower: 3.7x against
// 3.0x a read at 1024 x 512. A bin's first run of the frame reads zeros from a constant block
// instead of the bin (last frame's sums, out of cache), so that nothing is cleared between
// frames and the bin is only written (1024 x 512: 3.2x -> 3.0x). The pixels' values are
// computed eight at a time, a lane a pixel (LoadInterleaved3, then the scalar loop's
// operations), and transposed in 24 shuffles to eight vectors laid out as the bins, (r, g,
// b, lx, ly, lz, 0 l, 0 l): about 6 vector instructions a pixel against 14 for one pixel's
// vector built alone (3.0x -> 2.2x). On AVX-512 sixteen pixels go into 512-bit vectors
// (class Sixteen: ~40 shuffles for 16 pixels against ~66; 2.2x -> 1.9x at 1024 x 512), the
// run loop unrolled over the sixteen (rolled, its pixel vectors went through the stack:
// 2.5x). A row's last width % 8 pixels take that per-pixel form
// (its 16-byte load cleared by a bitwise and: a masked load measured 3.6x against 3.2x).
// The coarser levels are plain vector additions of four children, the three finest steps in
// one pass over 64-bin groups (the levels read back from L1, not from a pass of their own).
// On one core the whole prepare stayed at 1.9-2.0x a read at 1024 x 512 (73 % of it this
// pass). In bands of rows on both cores, each band's runs into bins it shares with an earlier
// band joined afterwards (the runs along the seam, a few hundred of some 240 000), and the
// finest steps' groups split between the cores too: 1.3-1.4x a read, 1.35x with the map out
// of cache (the floor is one core's read).
//
// Bit-identical to the scalar loops: the same operations on the same values in the same
// order (no fused multiply-add: -ffp-contract=off, and Highway's Mul/Add are separate
// instructions), each vector lane is one chain, and the luminance's lane sums equal the
// loop's (a + b = b + a in IEEE arithmetic).

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "sampling/q2tree_sums.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep

#include <hwy/highway.h>

#include <algorithm>
#include <vector>

#include "sampling/q2tree_sums.h"

namespace lp::detail {
// The plain loop over rows [first_row, end_row); with `later`, runs tagged kQ2LaterBand go there
// (without, they are added to their bins at once: the same chain when the map is one pass).
bool bin_sums_scalar(const float* rgb, const uint8_t* valid, size_t width, size_t first_row, size_t end_row,
                     const RowSources& s, float* bins, LaterRun* later);
}  // namespace lp::detail

HWY_BEFORE_NAMESPACE();
namespace lp::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

#if HWY_TARGET <= HWY_AVX3
// Sixteen pixels at a time in 512-bit vectors (AVX-512): the same values as the eight-pixel
// loop below (each lane the same operations), laid out as the bins in fewer shuffles a
// pixel. The loads are deinterleaved by two-table permutes straight into the lane order
// 0 2 4 6 | 1 3 5 7 | 8 10 12 14 | 9 11 13 15, which lets the transpose's last step put two
// neighbouring pixels into one vector with one permute: ~40 shuffles for 16 pixels (with the
// upper halves' extracts) against ~66 for two blocks of eight. Highway 1.0 has no two-table
// permute, hence the intrinsics.
class Sixteen {
 public:
  using F16 = hn::Full512<float>;
  using V16 = hn::Vec<F16>;

  explicit Sixteen(const float* row) {
    const hn::Full512<int32_t> i32;
    // Lane L holds pixel kPixel[L]; a table pair picks channel k of it from the first two
    // loads (floats 0-31), then from the third (floats 32-47, as 16-31).
    HWY_ALIGN static constexpr int32_t kPixel[16] = {0, 2, 4, 6, 1, 3, 5, 7, 8, 10, 12, 14, 9, 11, 13, 15};
    HWY_ALIGN int32_t table[2][16];
    for (int k = 0; k < 3; ++k) {
      for (int lane = 0; lane < 16; ++lane) {
        const int from = 3 * kPixel[lane] + k;
        table[0][lane] = from < 32 ? from : 0;
        table[1][lane] = from < 32 ? lane : 16 + from - 32;
      }
      from_ab_[k] = hn::Load(i32, table[0]).raw;
      from_c_[k] = hn::Load(i32, table[1]).raw;
    }
    HWY_ALIGN static constexpr int32_t kPairLow[16] = {0, 1, 2, 3, 16, 17, 18, 19, 4, 5, 6, 7, 20, 21, 22, 23};
    HWY_ALIGN static constexpr int32_t kPairHigh[16] = {8, 9, 10, 11, 24, 25, 26, 27, 12, 13, 14, 15, 28, 29, 30, 31};
    order_ = hn::Load(i32, kPixel).raw;
    pair_low_ = hn::Load(i32, kPairLow).raw;
    pair_high_ = hn::Load(i32, kPairHigh).raw;
    st_ = hn::Set(F16(), row[3]), ct_ = hn::Set(F16(), row[5]), dw_ = hn::Set(F16(), row[6]);
  }

  // Pixels px[0..16) (ok: their validity, or null) into p[0..16), laid out as the bins;
  // low: the smallest r, g, b seen.
  HWY_INLINE void operator()(const float* px, const uint8_t* ok, const float* cos_phi, const float* sin_phi,
                             hn::Vec<hn::Full256<float>>* p, V16& low) const {
    const F16 f;
    const hn::Full512<int32_t> i32;
    const __m512i a = _mm512_castps_si512(_mm512_loadu_ps(px)), b = _mm512_castps_si512(_mm512_loadu_ps(px + 16)),
                  c = _mm512_castps_si512(_mm512_loadu_ps(px + 32));
    auto channel = [&](int k) {
      const __m512i ab = _mm512_permutex2var_epi32(a, from_ab_[k], b);
      return V16{_mm512_castsi512_ps(_mm512_permutex2var_epi32(ab, from_c_[k], c))};
    };
    V16 r = channel(0), g = channel(1), bl = channel(2);
    if (ok) {
      const __m512i bytes = _mm512_cvtepu8_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(ok)));
      const auto m = hn::RebindMask(f, hn::Ne(hn::Vec<decltype(i32)>{_mm512_permutexvar_epi32(order_, bytes)},
                                              hn::Zero(i32)));
      r = hn::IfThenElseZero(m, r), g = hn::IfThenElseZero(m, g), bl = hn::IfThenElseZero(m, bl);
    }
    const auto zero = hn::Zero(f);
    const auto R = hn::Mul(r, dw_), G = hn::Mul(g, dw_), B = hn::Mul(bl, dw_);
    low = hn::Min(B, hn::Min(G, hn::Min(R, low)));
    const auto l = hn::Add(hn::Add(hn::Mul(R, hn::Set(f, 0.2126f)), hn::Mul(G, hn::Set(f, 0.7152f))),
                           hn::Add(hn::Mul(B, hn::Set(f, 0.0722f)), zero));
    const V16 cos16{_mm512_permutexvar_ps(order_, _mm512_loadu_ps(cos_phi))};
    const V16 sin16{_mm512_permutexvar_ps(order_, _mm512_loadu_ps(sin_phi))};
    const auto X = hn::Mul(l, hn::Mul(st_, cos16));
    const auto Y = hn::Mul(l, hn::Mul(st_, sin16));
    const auto Z = hn::Mul(l, ct_);
    const auto W = hn::Mul(l, zero);
    const auto t0 = hn::InterleaveLower(f, R, G), t1 = hn::InterleaveUpper(f, R, G);
    const auto t2 = hn::InterleaveLower(f, B, X), t3 = hn::InterleaveUpper(f, B, X);
    const auto t4 = hn::InterleaveLower(f, Y, Z), t5 = hn::InterleaveUpper(f, Y, Z);
    const auto t6 = hn::InterleaveLower(f, W, W), t7 = hn::InterleaveUpper(f, W, W);
    const hn::Repartition<double, F16> d8;
    auto pairs = [&](V16 lo, V16 hi, bool upper) {
      const auto x = hn::BitCast(d8, lo), y = hn::BitCast(d8, hi);
      return hn::BitCast(f, upper ? hn::InterleaveUpper(d8, x, y) : hn::InterleaveLower(d8, x, y));
    };
    // Block b of us[i]: channels 0-3 of lane 4 b + i's pixel; of vs[i]: channels 4-7.
    const V16 us[4] = {pairs(t0, t2, false), pairs(t0, t2, true), pairs(t1, t3, false), pairs(t1, t3, true)};
    const V16 vs[4] = {pairs(t4, t6, false), pairs(t4, t6, true), pairs(t5, t7, false), pairs(t5, t7, true)};
    const hn::Full256<float> f8;
    for (int i = 0; i < 4; ++i) {  // pixels 2i, 2i + 1 and 8 + 2i, 9 + 2i
      const V16 low_pair{_mm512_permutex2var_ps(us[i].raw, pair_low_, vs[i].raw)};
      const V16 high_pair{_mm512_permutex2var_ps(us[i].raw, pair_high_, vs[i].raw)};
      p[2 * i] = hn::LowerHalf(f8, low_pair), p[2 * i + 1] = hn::UpperHalf(f8, low_pair);
      p[8 + 2 * i] = hn::LowerHalf(f8, high_pair), p[9 + 2 * i] = hn::UpperHalf(f8, high_pair);
    }
  }

 private:
  __m512i from_ab_[3], from_c_[3], order_, pair_low_, pair_high_;
  V16 st_, ct_, dw_;
};
#endif

// Rows [first_row, end_row) of the map's `height`; runs tagged kQ2LaterBand go to `later`.
bool Q2treeBinSums(const float* rgb, const uint8_t* valid, size_t width, size_t height, size_t first_row,
                   size_t end_row, const RowSources& s, float* bins, LaterRun* later) {
#if HWY_TARGET <= HWY_AVX2
  const hn::Full256<float> f8;
  const hn::Full128<float> f4;
  HWY_ALIGN static constexpr float kLuminance[4] = {0.2126f, 0.7152f, 0.0722f, 0.0f};
  const auto weights = hn::Load(f4, kLuminance);
  const auto rgb_lanes = hn::FirstN(f4, 3);
  const auto rgb_bits = hn::VecFromMask(f4, rgb_lanes);  // all ones in lanes 0-2
  auto low = hn::Zero(f4);  // the smallest r, g, b seen (lane 3 stays 0)
  auto low8 = hn::Zero(f8);  // the same over the eight-pixel blocks
  HWY_ALIGN static constexpr float kZeros[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  const size_t last_pixel = width * height - 1;
#if HWY_TARGET <= HWY_AVX3
  auto low16 = hn::Zero(hn::Full512<float>());
#endif
  for (size_t v = first_row; v < end_row; ++v) {
    const float* row = s.row + 8 * v;
    const auto row8 = hn::LoadU(f8, row);
    const auto dw = hn::Set(f4, row[6]);
    const uint32_t* target = s.target + v * width;
    const uint8_t* ok = valid ? valid + v * width : nullptr;
    const float* px = rgb + 3 * v * width;
    // A run of pixels with the same healpix pixel is summed in a register and added to its
    // bin once (one load and store a run instead of a pixel, and no store-to-load chain).
    // A bin's first run reads zeros from kZeros instead of the bin (last frame's sums, likely
    // out of cache), so that only the store goes to the bin.
    const auto add_run = [&](uint32_t tagged, decltype(hn::Zero(f8)) sum) {
      if (HWY_UNLIKELY(tagged & kQ2LaterBand)) {  // an earlier band's runs come first
        hn::Store(sum, f8, later->sum);
        (later++)->pixel = tagged & kQ2Pixel;
        return;
      }
      float* bin = bins + 8 * size_t(tagged & kQ2Pixel);
      const float* from = (tagged & kQ2FirstRun) ? kZeros : bin;
      hn::Store(hn::Add(hn::Load(f8, from), sum), f8, bin);
    };
    auto run = hn::Zero(f8);
    uint32_t current = width ? target[0] : 0;  // the run's tagged target
    // The next pixel's tagged target: where it is another healpix pixel, the run ends.
    const auto next_target = [&](uint32_t tagged) {
      if ((tagged ^ current) & kQ2Pixel) {
        add_run(current, run);
        run = hn::Zero(f8);
        current = tagged;
      }
    };
    // Eight pixels at a time: their values computed with a lane a pixel, then transposed to
    // eight vectors laid out as the bins, (r, g, b, lx, ly, lz, 0 l, 0 l) (24 shuffles).
    size_t u = 0;
    const auto st8 = hn::Set(f8, row[3]), ct8 = hn::Set(f8, row[5]), dw8 = hn::Set(f8, row[6]);
    const auto zero8 = hn::Zero(f8);
#if HWY_TARGET <= HWY_AVX3
    const Sixteen sixteen(row);
    for (; u + 16 <= width; u += 16) {
      hn::Vec<decltype(f8)> p[16];
      sixteen(px + 3 * u, ok ? ok + u : nullptr, s.cos_phi + u, s.sin_phi + u, p, low16);
#pragma GCC unroll 16
      for (size_t j = 0; j < 16; ++j) {
        next_target(target[u + j]);
        run = hn::Add(run, p[j]);
      }
    }
#endif
    for (; u + 8 <= width; u += 8) {
      hn::Vec<decltype(f8)> r, g, b;
      hn::LoadInterleaved3(f8, px + 3 * u, r, g, b);
      if (ok) {
        const auto bytes = hn::LoadU(hn::Full64<uint8_t>(), ok + u);
        const auto m = hn::RebindMask(f8, hn::Ne(hn::PromoteTo(hn::Full256<int32_t>(), bytes), hn::Zero(hn::Full256<int32_t>())));
        r = hn::IfThenElseZero(m, r), g = hn::IfThenElseZero(m, g), b = hn::IfThenElseZero(m, b);
      }
      const auto R = hn::Mul(r, dw8), G = hn::Mul(g, dw8), B = hn::Mul(b, dw8);
      low8 = hn::Min(B, hn::Min(G, hn::Min(R, low8)));
      const auto l = hn::Add(hn::Add(hn::Mul(R, hn::Set(f8, 0.2126f)), hn::Mul(G, hn::Set(f8, 0.7152f))),
                             hn::Add(hn::Mul(B, hn::Set(f8, 0.0722f)), zero8));
      const auto X = hn::Mul(l, hn::Mul(st8, hn::LoadU(f8, s.cos_phi + u)));
      const auto Y = hn::Mul(l, hn::Mul(st8, hn::LoadU(f8, s.sin_phi + u)));
      const auto Z = hn::Mul(l, ct8);
      const auto W = hn::Mul(l, zero8);
      const auto t0 = hn::InterleaveLower(f8, R, G), t1 = hn::InterleaveUpper(f8, R, G);
      const auto t2 = hn::InterleaveLower(f8, B, X), t3 = hn::InterleaveUpper(f8, B, X);
      const auto t4 = hn::InterleaveLower(f8, Y, Z), t5 = hn::InterleaveUpper(f8, Y, Z);
      const auto t6 = hn::InterleaveLower(f8, W, W), t7 = hn::InterleaveUpper(f8, W, W);
      const hn::Repartition<double, decltype(f8)> d4;
      auto pairs = [&](decltype(t0) lo, decltype(t0) hi, bool upper) {
        const auto a = hn::BitCast(d4, lo), c = hn::BitCast(d4, hi);
        return hn::BitCast(f8, upper ? hn::InterleaveUpper(d4, a, c) : hn::InterleaveLower(d4, a, c));
      };
      const auto u0 = pairs(t0, t2, false), u1 = pairs(t0, t2, true), u2 = pairs(t1, t3, false), u3 = pairs(t1, t3, true);
      const auto v0 = pairs(t4, t6, false), v1 = pairs(t4, t6, true), v2 = pairs(t5, t7, false), v3 = pairs(t5, t7, true);
      const decltype(u0) p[8] = {hn::ConcatLowerLower(f8, v0, u0), hn::ConcatLowerLower(f8, v1, u1),
                                 hn::ConcatLowerLower(f8, v2, u2), hn::ConcatLowerLower(f8, v3, u3),
                                 hn::ConcatUpperUpper(f8, v0, u0), hn::ConcatUpperUpper(f8, v1, u1),
                                 hn::ConcatUpperUpper(f8, v2, u2), hn::ConcatUpperUpper(f8, v3, u3)};
      for (size_t j = 0; j < 8; ++j) {
        next_target(target[u + j]);
        run = hn::Add(run, p[j]);
      }
    }
    for (; u < width; ++u) {
      next_target(target[u]);
      if (ok && !ok[u]) continue;
      // (r, g, b, next pixel's r): the fourth float is read only where it exists, and cleared.
      hn::Vec<decltype(f4)> p4;
      if (HWY_LIKELY(v * width + u != last_pixel)) {
        p4 = hn::And(hn::LoadU(f4, px + 3 * u), rgb_bits);
      } else {
        HWY_ALIGN float last[4] = {px[3 * u], px[3 * u + 1], px[3 * u + 2], 0.0f};
        p4 = hn::Load(f4, last);
      }
      const auto c = hn::Mul(p4, dw);  // r, g, b, 0
      low = hn::Min(c, low);           // (x86 min: a NaN in c keeps low)
      const auto m = hn::Mul(c, weights);
      const auto a = hn::Add(m, hn::Shuffle2301(m));  // m0 + m1, m0 + m1, m2 + 0, m2 + 0
      const auto l = hn::Add(a, hn::Shuffle1032(a));  // l in every lane
      const auto p8 = hn::Combine(f8, l, hn::IfThenElse(rgb_lanes, c, l));  // r, g, b, l | l, l, l, l
      const auto dir = hn::Mul(row8, hn::LoadU(f8, s.col + 8 * u));
      run = hn::Add(run, hn::Mul(p8, dir));
    }
    if (width) add_run(current, run);
  }
  HWY_ALIGN float flags[4];
  hn::Store(low, f4, flags);
#if HWY_TARGET <= HWY_AVX3
  low8 = hn::Min(low8, hn::Min(hn::LowerHalf(f8, low16), hn::UpperHalf(f8, low16)));
#endif
  return flags[0] < 0 || flags[1] < 0 || flags[2] < 0 || !hn::AllFalse(f8, hn::Lt(low8, hn::Zero(f8)));
#else  // 128-bit vectors would split every pixel in two: the plain loop
  return bin_sums_scalar(rgb, valid, width, first_row, end_row, s, bins, later);
#endif
}

HWY_INLINE void QuadSum(const float* c, float* parent) {
  const hn::CappedTag<float, 8> d;
  for (size_t k = 0; k < 8; k += hn::Lanes(d)) {  // 8 floats: one vector from AVX2 on
    const auto a = hn::Add(hn::Load(d, c + k), hn::Load(d, c + 8 + k));
    const auto b = hn::Add(hn::Load(d, c + 16 + k), hn::Load(d, c + 24 + k));
    hn::Store(hn::Add(a, b), d, parent + k);
  }
}

void Q2treeQuadSums(const float* child, size_t parents, float* parent) {
  for (size_t p = 0; p < parents; ++p) QuadSum(child + 32 * p, parent + 8 * p);
}

// Three levels in one pass: each group of 64 children gives 16 parents, 4 grandparents and
// 1 great-grandparent, the last two summed from the ones just written (in L1) instead of in
// a pass of their own over the level below.
void Q2treeQuadSums3(const float* child, size_t groups, float* level1, float* level2, float* level3) {
  for (size_t g = 0; g < groups; ++g) {
    for (size_t p = 0; p < 16; ++p) QuadSum(child + 8 * (64 * g + 4 * p), level1 + 8 * (16 * g + p));
    for (size_t p = 0; p < 4; ++p) QuadSum(level1 + 8 * (16 * g + 4 * p), level2 + 8 * (4 * g + p));
    QuadSum(level2 + 8 * (4 * g), level3 + 8 * g);
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace lp::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
#include <tbb/parallel_for.h>

namespace lp::detail {

HWY_EXPORT(Q2treeBinSums);
HWY_EXPORT(Q2treeQuadSums);
HWY_EXPORT(Q2treeQuadSums3);

bool q2tree_bin_sums(const float* rgb, const uint8_t* valid, size_t width, size_t height, const RowSources& sources,
                     float* bins) {
  if (sources.bands <= 1)
    return HWY_DYNAMIC_DISPATCH(Q2treeBinSums)(rgb, valid, width, height, 0, height, sources, bins, nullptr);
  // Each band's runs into bins an earlier band also fills wait in `later`, then join their bins
  // in band order: every bin's chain of additions is the one-pass loop's.
  std::vector<size_t> first_later(sources.bands + 1, 0);
  for (size_t b = 0; b < sources.bands; ++b) first_later[b + 1] = first_later[b] + sources.band_later_runs[b];
  std::vector<LaterRun> later(first_later.back());
  std::vector<uint8_t> negative(sources.bands, 0);
  tbb::parallel_for(size_t(0), sources.bands, [&](size_t b) {
    negative[b] = HWY_DYNAMIC_DISPATCH(Q2treeBinSums)(rgb, valid, width, height, sources.band_rows[b],
                                                      sources.band_rows[b + 1], sources, bins,
                                                      later.data() + first_later[b]);
  });
  for (const LaterRun& run : later) {
    float* bin = bins + 8 * size_t(run.pixel);
    for (int k = 0; k < 8; ++k) bin[k] = bin[k] + run.sum[k];
  }
  return std::find(negative.begin(), negative.end(), 1) != negative.end();
}

RunTags q2tree_tag_runs(uint32_t* target, size_t width, size_t height, size_t bands) {
  bands = std::clamp<size_t>(bands, 1, std::max<size_t>(1, height));
  RunTags tags;
  for (size_t b = 0; b <= bands; ++b) tags.band_rows.push_back(uint32_t(height * b / bands));
  tags.band_later_runs.assign(bands, 0);
  const uint32_t pixels = width != 0 && height != 0 ? *std::max_element(target, target + width * height) + 1 : 0;
  std::vector<uint32_t> first_band(pixels, UINT32_MAX);  // the band of each healpix pixel's first run
  for (size_t b = 0; b < bands; ++b)
    for (size_t v = tags.band_rows[b]; v < tags.band_rows[b + 1]; ++v)
      for (size_t u = 0; u < width; ++u) {
        uint32_t& t = target[v * width + u];
        if (u > 0 && (target[v * width + u - 1] & kQ2Pixel) == t) continue;  // not a run's first pixel
        if (first_band[t] == UINT32_MAX) {
          first_band[t] = uint32_t(b);
          t |= kQ2FirstRun;
        } else if (first_band[t] < b) {
          t |= kQ2LaterBand;
          ++tags.band_later_runs[b];
        }
      }
  return tags;
}

void q2tree_quad_sums(const float* child, size_t parents, float* parent) {
  HWY_DYNAMIC_DISPATCH(Q2treeQuadSums)(child, parents, parent);
}

void q2tree_quad_sums3(const float* child, size_t groups, float* level1, float* level2, float* level3) {
  HWY_DYNAMIC_DISPATCH(Q2treeQuadSums3)(child, groups, level1, level2, level3);
}

bool q2tree_bin_sums_scalar(const float* rgb, const uint8_t* valid, size_t width, size_t height, const RowSources& s,
                            float* bins) {
  return bin_sums_scalar(rgb, valid, width, 0, height, s, bins, nullptr);
}

bool bin_sums_scalar(const float* rgb, const uint8_t* valid, size_t width, size_t first_row, size_t end_row,
                     const RowSources& s, float* bins, LaterRun* later) {
  bool negative = false;
  for (size_t v = first_row; v < end_row; ++v) {
    const float* row = s.row + 8 * v;
    float run[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    auto add_run = [&](uint32_t tagged) {
      if (later && (tagged & kQ2LaterBand)) {
        for (int k = 0; k < 8; ++k) later->sum[k] = run[k], run[k] = 0.0f;
        (later++)->pixel = tagged & kQ2Pixel;
        return;
      }
      float* bin = bins + 8 * size_t(tagged & kQ2Pixel);
      for (int k = 0; k < 8; ++k) bin[k] = ((tagged & kQ2FirstRun) ? 0.0f : bin[k]) + run[k], run[k] = 0.0f;
    };
    uint32_t current = width ? s.target[v * width] : 0;
    for (size_t u = 0; u < width; ++u) {
      const size_t i = v * width + u;
      if ((s.target[i] ^ current) & kQ2Pixel) {
        add_run(current);
        current = s.target[i];
      }
      if (valid && !valid[i]) continue;
      const float* col = s.col + 8 * u;
      const float dw = row[6];
      const float r = rgb[3 * i] * dw, g = rgb[3 * i + 1] * dw, b = rgb[3 * i + 2] * dw;
      negative |= (r < 0) | (g < 0) | (b < 0);
      const float l = (0.2126f * r + 0.7152f * g) + (0.0722f * b + 0.0f);
      const float values[8] = {r, g, b, l, l, l, l, l};
      for (int k = 0; k < 8; ++k) run[k] += values[k] * (row[k] * col[k]);
    }
    if (width) add_run(current);
  }
  return negative;
}

void q2tree_quad_sums_scalar(const float* child, size_t parents, float* parent) {
  for (size_t p = 0; p < parents; ++p)
    for (int k = 0; k < 8; ++k) {
      const float* c = child + 32 * p + k;
      parent[8 * p + k] = (c[0] + c[8]) + (c[16] + c[24]);
    }
}

}  // namespace lp::detail
#endif  // HWY_ONCE
