// The merge's row kernel in Google Highway (see merge_kernel.h). This file is compiled once
// per target: hwy/foreach_target.h includes it again for SSSE3, SSE4, AVX2 and AVX-512 (and
// the scalar fallback), each copy in its own namespace with its own instruction set, and
// HWY_DYNAMIC_DISPATCH picks the best one the CPU has at the first call. The build itself
// stays baseline x86-64.
//
// Why it is faster than the scalar loop (hdr/merge.cpp): the scalar loop spends 74 % of the
// merge on per-channel table lookups, one code at a time, through row buffers of partial
// sums written and re-read once per frame, and a third of the benchmark's pixels (clipped or
// black in every frame) in its per-pixel fallback with a double exp() each. Here one vector
// holds N interleaved channel codes (N = 16 floats with AVX-512): the level, the table index
// and one 64-bit read of both tables (LookUp) are N lanes at a time, the sums of all frames
// stay in registers, the bounds of clipped and black channels come from two precomputed
// tables, and the division and store happen once. The table reads are what it waits for.
// Measured on this project's 2-core VM (AMD EPYC with AVX-512), the benchmark's 3x1280x960
// bracket on one thread (best of 7): scalar loop 36.7 ms; kernel AVX-512 9.6 ms, AVX2 11.1,
// SSE4 13.9, SSSE3 21.5, Highway's one-lane fallback 37.6 (reading w and wx as two gathers
// instead of one paired read: AVX-512 20.1 ms, AVX2 14.8). Two threads: docs/performance.md.
// Since then (docs/hdr.md, "Speed"): a frame whose vector of codes is all black or clipped
// skips its reads (they would add +0), and a bound table is read only when some lane takes
// it: one thread's CPU time on that bracket 9.1-9.4 -> 5.2-5.3 ms (AVX-512, load 6-7).
// Not done, and why: in-register lookups (the 256-level tables in vector registers instead of
// gathers) need a two-table permute (vpermt2ps; Highway's TwoTablesLookupLanes) that the
// Highway 1.0.3 in Debian 12 does not have; with single 16-lane TableLookupLanes a 256-entry
// table takes 16 lookups and 15 selects per vector and table, more than the gather costs.
//
// Bit-identical to the scalar loop: every lane does the scalar loop's operations in its order
// (level = int(min(z * scale + 0.5, levels - 1)) after zeroing non-positive and NaN values;
// sum += table[level] * factor per frame, frames in order; one division), with no fused
// multiply-add (hdr/CMakeLists.txt compiles this file and merge.cpp with -ffp-contract=off,
// and Highway's Mul/Add are separate instructions), and IEEE division on every target.

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "hdr/merge_kernel.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep

#include <hwy/highway.h>

#include "hdr/merge.h"
#include "hdr/merge_kernel.h"

HWY_BEFORE_NAMESPACE();
namespace lp::detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// w[index] and wx[index] for every lane. One 64-bit read per lane fetches both (w_wx): half
// the reads of two tables (AVX-512 on one thread: 20.1 -> 9.6 ms of the merge, see above).
template <class DF, class VI>
HWY_INLINE void LookUp(DF df, const MergeRowInput& in, VI index, hn::Vec<DF>& w, hn::Vec<DF>& wx) {
#if HWY_TARGET == HWY_SCALAR
  w = hn::GatherIndex(df, in.w, index);  // one lane: nothing to pair
  wx = hn::GatherIndex(df, in.wx, index);
#else
  const hn::Repartition<uint64_t, DF> du64;  // half as many lanes
  const hn::RebindToSigned<decltype(du64)> di64;
  const hn::Half<hn::RebindToSigned<DF>> dhalf;
  const auto lower = hn::BitCast(df, hn::GatherIndex(du64, in.w_wx, hn::PromoteTo(di64, hn::LowerHalf(dhalf, index))));
  const auto upper = hn::BitCast(df, hn::GatherIndex(du64, in.w_wx, hn::PromoteTo(di64, hn::UpperHalf(dhalf, index))));
  w = hn::ConcatEven(df, upper, lower);
  wx = hn::ConcatOdd(df, upper, lower);
#endif
}

MergeRowResult MergeRow(const MergeRowInput& in, float* out, uint8_t* flags, uint32_t* redo) {
  const hn::ScalableTag<float> df;
  const hn::RebindToSigned<decltype(df)> di;
  using VF = hn::Vec<decltype(df)>;
  using VI = hn::Vec<decltype(di)>;
  const size_t N = hn::Lanes(df);
  // A group of N pixels is 3 vectors of N interleaved codes; lane j of vector v holds channel
  // (v N + j) mod 3, whose table starts at that channel times `levels`.
  HWY_ALIGN int32_t channel_offset[3 * hn::MaxLanes(df)];
  for (size_t i = 0; i < 3 * N; ++i) channel_offset[i] = int32_t(i % 3) * in.levels;
  VI offset[3];
  for (size_t v = 0; v < 3; ++v) offset[v] = hn::Load(di, channel_offset + v * N);
  const VF scale = hn::Set(df, float(in.levels - 1));  // code -> level, before + 0.5
  const VF half = hn::Set(df, 0.5f);
  const VF top = hn::Set(df, float(in.levels - 1));
  const VF zero = hn::Zero(df);
  const VI zero_through = hn::Set(di, in.zero_through), zero_from = hn::Set(di, in.zero_from);
  const VI below_sat = hn::Set(di, in.sat_level - 1);
  const VI above_black = hn::Set(di, in.black_level + 1);
  const VI first = hn::Set(di, in.levels), last = hn::Set(di, -1), none_yet = hn::Zero(di);
  // Per lane of a group with a channel no frame weighs: 1 saturated, 2 black, 4 neither.
  constexpr int32_t kMixed = 4;
  static_assert(kSaturatedEverywhere == 1 && kBlackEverywhere == 2, "lane codes are the flag bits");
  HWY_ALIGN int32_t lane_code[3 * hn::MaxLanes(df)];
  const size_t groups = in.width / N;
  MergeRowResult result;
  for (size_t g = 0; g < groups; ++g) {
    const size_t first_float = 3 * N * g;
    VF sw[3] = {zero, zero, zero}, swx[3] = {zero, zero, zero};
    VI lowest[3] = {first, first, first}, highest[3] = {last, last, last};  // levels over the frames
    // Table indices of the levels in the shortest and the longest frame.
    VI at_shortest[3] = {none_yet, none_yet, none_yet}, at_longest[3] = {none_yet, none_yet, none_yet};
    for (size_t k = 0; k < in.frames; ++k) {
      const float* z = in.rows[k] + first_float;
      const VF fw = hn::Set(df, in.frame_w[k]);
      const VF fx = hn::Set(df, in.frame_wx[k]);
      for (size_t v = 0; v < 3; ++v) {
        VF s = hn::Add(hn::Mul(hn::LoadU(df, z + v * N), scale), half);
        s = hn::IfThenElseZero(hn::Gt(s, zero), s);  // level 0 at or below 0 and for NaN
        const VI level = hn::ConvertTo(di, hn::Min(s, top));
        lowest[v] = hn::Min(lowest[v], level);
        highest[v] = hn::Max(highest[v], level);
        const VI index = hn::Add(level, offset[v]);
        if (k == in.shortest) at_shortest[v] = index;
        if (k == in.longest) at_longest[v] = index;
        // Every lane black or clipped in this frame: it adds +0 to both sums, so skip the reads.
        if (hn::AllFalse(di, hn::And(hn::Gt(level, zero_through), hn::Lt(level, zero_from)))) continue;
        VF w, wx;
        LookUp(df, in, index, w, wx);
        sw[v] = hn::Add(sw[v], hn::Mul(w, fw));
        swx[v] = hn::Add(swx[v], hn::Mul(wx, fx));
      }
    }
    bool all_weighted = true;
    VF value[3];
    for (size_t v = 0; v < 3; ++v) {
      value[v] = hn::Div(swx[v], sw[v]);
      all_weighted = all_weighted && hn::AllTrue(df, hn::Gt(sw[v], zero));
    }
    if (HWY_UNLIKELY(!all_weighted)) {  // a channel clipped or black in every frame
      for (size_t v = 0; v < 3; ++v) {
        const auto none = hn::Not(hn::Gt(sw[v], zero));
        const auto sat = hn::Gt(lowest[v], below_sat);
        const auto black = hn::Lt(highest[v], above_black);
        // Unweighted lanes saturated everywhere take the shortest frame's bound, the others the
        // longest's; each table is read only when some lane takes it (in a clipped or black
        // region, one of the two).
        const auto sat_f = hn::RebindMask(df, sat);
        const auto take_short = hn::And(none, sat_f);
        const auto take_long = hn::AndNot(sat_f, none);
        if (!hn::AllFalse(df, take_short))
          value[v] = hn::IfThenElse(take_short, hn::GatherIndex(df, in.bound_short, at_shortest[v]), value[v]);
        if (!hn::AllFalse(df, take_long))
          value[v] = hn::IfThenElse(take_long, hn::GatherIndex(df, in.bound_long, at_longest[v]), value[v]);
        const VI code = hn::IfThenElse(sat, hn::Set(di, 1), hn::IfThenElse(black, hn::Set(di, 2), hn::Set(di, kMixed)));
        hn::Store(hn::IfThenElseZero(hn::RebindMask(di, none), code), di, lane_code + v * N);
      }
      for (size_t p = 0; p < N; ++p) {
        const int32_t c = lane_code[3 * p] | lane_code[3 * p + 1] | lane_code[3 * p + 2];
        if (c & kMixed) {
          redo[result.redone++] = uint32_t(N * g + p);
        } else if (c) {
          result.saturated += c & kSaturatedEverywhere;
          result.black += (c & kBlackEverywhere) >> 1;
          ++result.flagged;
          if (flags) flags[N * g + p] = uint8_t(c);
        }
      }
    }
    for (size_t v = 0; v < 3; ++v) hn::StoreU(value[v], df, out + first_float + v * N);
  }
  result.done = groups * N;
  return result;
}

const char* MergeTargetName() { return hwy::TargetName(HWY_TARGET); }

}  // namespace HWY_NAMESPACE
}  // namespace lp::detail
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace lp::detail {

HWY_EXPORT(MergeRow);
HWY_EXPORT(MergeTargetName);

MergeRowResult merge_row_simd(const MergeRowInput& in, float* out, uint8_t* flags, uint32_t* redo) {
  return HWY_DYNAMIC_DISPATCH(MergeRow)(in, out, flags, redo);
}

const char* merge_simd_target() { return HWY_DYNAMIC_DISPATCH(MergeTargetName)(); }

}  // namespace lp::detail
#endif  // HWY_ONCE
