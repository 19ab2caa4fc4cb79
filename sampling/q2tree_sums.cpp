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
// vector built alone (3.0x -> 2.2x). A row's last width % 8 pixels take that per-pixel form
// (its 16-byte load cleared by a bitwise and: a masked load measured 3.6x against 3.2x).
// The coarser levels are plain vector additions of four children.
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

#include "sampling/q2tree_sums.h"

HWY_BEFORE_NAMESPACE();
namespace lp::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

bool Q2treeBinSums(const float* rgb, const uint8_t* valid, size_t width, size_t height, const RowSources& s,
                   float* bins) {
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
  for (size_t v = 0; v < height; ++v) {
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
      float* bin = bins + 8 * size_t(tagged & ~kQ2FirstRun);
      const float* from = (tagged & kQ2FirstRun) ? kZeros : bin;
      hn::Store(hn::Add(hn::Load(f8, from), sum), f8, bin);
    };
    auto run = hn::Zero(f8);
    uint32_t current = width ? target[0] : 0;  // the run's tagged target
    // Eight pixels at a time: their values computed with a lane a pixel, then transposed to
    // eight vectors laid out as the bins, (r, g, b, lx, ly, lz, 0 l, 0 l) (24 shuffles).
    size_t u = 0;
    const auto st8 = hn::Set(f8, row[3]), ct8 = hn::Set(f8, row[5]), dw8 = hn::Set(f8, row[6]);
    const auto zero8 = hn::Zero(f8);
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
        if ((target[u + j] ^ current) & ~kQ2FirstRun) {
          add_run(current, run);
          run = hn::Zero(f8);
          current = target[u + j];
        }
        run = hn::Add(run, p[j]);
      }
    }
    for (; u < width; ++u) {
      if ((target[u] ^ current) & ~kQ2FirstRun) {
        add_run(current, run);
        run = hn::Zero(f8);
        current = target[u];
      }
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
  return flags[0] < 0 || flags[1] < 0 || flags[2] < 0 || !hn::AllFalse(f8, hn::Lt(low8, hn::Zero(f8)));
#else  // 128-bit vectors would split every pixel in two: the plain loop
  return q2tree_bin_sums_scalar(rgb, valid, width, height, s, bins);
#endif
}

void Q2treeQuadSums(const float* child, size_t parents, float* parent) {
  const hn::CappedTag<float, 8> d;
  for (size_t p = 0; p < parents; ++p) {
    const float* c = child + 32 * p;
    for (size_t k = 0; k < 8; k += hn::Lanes(d)) {  // 8 floats: one vector from AVX2 on
      const auto a = hn::Add(hn::Load(d, c + k), hn::Load(d, c + 8 + k));
      const auto b = hn::Add(hn::Load(d, c + 16 + k), hn::Load(d, c + 24 + k));
      hn::Store(hn::Add(a, b), d, parent + 8 * p + k);
    }
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace lp::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace lp::detail {

HWY_EXPORT(Q2treeBinSums);
HWY_EXPORT(Q2treeQuadSums);

bool q2tree_bin_sums(const float* rgb, const uint8_t* valid, size_t width, size_t height, const RowSources& sources,
                     float* bins) {
  return HWY_DYNAMIC_DISPATCH(Q2treeBinSums)(rgb, valid, width, height, sources, bins);
}

void q2tree_quad_sums(const float* child, size_t parents, float* parent) {
  HWY_DYNAMIC_DISPATCH(Q2treeQuadSums)(child, parents, parent);
}

bool q2tree_bin_sums_scalar(const float* rgb, const uint8_t* valid, size_t width, size_t height, const RowSources& s,
                            float* bins) {
  bool negative = false;
  for (size_t v = 0; v < height; ++v) {
    const float* row = s.row + 8 * v;
    float run[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    auto add_run = [&](uint32_t tagged) {
      float* bin = bins + 8 * size_t(tagged & ~kQ2FirstRun);
      for (int k = 0; k < 8; ++k) bin[k] = ((tagged & kQ2FirstRun) ? 0.0f : bin[k]) + run[k], run[k] = 0.0f;
    };
    uint32_t current = width ? s.target[v * width] : 0;
    for (size_t u = 0; u < width; ++u) {
      const size_t i = v * width + u;
      if ((s.target[i] ^ current) & ~kQ2FirstRun) {
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
