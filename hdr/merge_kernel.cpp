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
// and one 64-bit read of both tables (FrameSums) are N lanes at a time, the sums of all frames
// stay in registers, the bounds of clipped and black channels come from two precomputed
// tables, and the division and store happen once. The table reads are what it waits for.
// Measured on this project's 2-core VM (AMD EPYC with AVX-512), the benchmark's 3x1280x960
// bracket on one thread (best of 7): scalar loop 36.7 ms; kernel AVX-512 9.6 ms, AVX2 11.1,
// SSE4 13.9, SSSE3 21.5, Highway's one-lane fallback 37.6 (reading w and wx as two gathers
// instead of one paired read: AVX-512 20.1 ms, AVX2 14.8). Two threads: docs/performance.md.
// Since then (docs/hdr.md, "Speed"): a frame whose vector of codes is all black or clipped
// skips its reads (they would add +0), and a bound table is read only when some lane takes
// it: one thread's CPU time on that bracket 9.1-9.4 -> 5.2-5.3 ms (AVX-512, load 6-7).
// Then (issue 23, the 3x-floor aim): the (w, wx) pairs stay paired in the sums and are split
// once per group instead of once per frame (FrameSums); the level's conversion and the
// 64-bit gather by 32-bit indices use each x86 target's own instruction where Highway 1.0.3
// adds work (LevelOf, Gather64: the widenings and an overflow fix-up that the clamp already
// rules out); the levels over the frames, which only the rare unweighted channels need, are
// computed again for them instead of tracked for every pixel; a flat black or clipped vector
// takes its bound from a register instead of a gather; and the per-pixel codes are ORed and
// counted as vectors. One thread's CPU time, median of 5, four interleaved runs at load 3.5:
// 5.0-5.1 -> 4.2 ms.
// Then (issue 23, a third pass): on CPUs with AVX-512 VBMI and 256-level tables the AVX3
// target hands the row's blocks of 64 pixels to merge_kernel_vbmi.cpp, which reads the tables
// by byte permutes (vpermi2b on 4 byte planes per table, in registers) instead of gathers,
// per channel plane of 64 codes; the rest of the row stays here. Raw intrinsics in a file of
// their own: Highway 1.0.3 (Debian 12) has no two-table permute (TwoTablesLookupLanes) and
// compiles no AVX3_DL target by default, and with its single 16-lane TableLookupLanes a
// 256-entry table takes 16 lookups and 15 selects per vector and table, more than a gather.
// One thread's CPU time on the benchmark, medians of six interleaved runs at load 4-5:
// 4.60 -> 3.42 ms (docs/hdr.md). It now waits on reading the brackets (its prefetches and
// first loads are where its samples are); streaming stores of the output did not help.
// Then (issue 23, 8-bit input): an 8-bit bracket keeps its codes (Bracket::codes), which are
// the levels at 256 levels, and both kernels read them (MergeRowInput::codes: 1 byte per
// channel code instead of a float and its conversion; 11 instead of 44 MB per merge of the
// benchmark's bracket). One thread's CPU time, medians of 5, six interleaved runs at load
// 4-4.7: 3.67 ms (float frames, before) -> 1.98 ms (8-bit frames); float frames unchanged.
// Against the floor that reads three 8-bit frames (the honest one for this path, issue 23's
// "read 3 brackets"), 2 threads: 3.6x, so the 3x aim is not met; against the float floor
// 1.65x. perf then puts ~12 % of the VBMI kernel's samples on the code loads and prefetches
// (was ~40 % on the floats'), the rest on its own work: the byte permutes, unpacks and blends
// of the table reads, the divisions, the spills of its per-block arrays. 16-bit, RAW and float
// brackets keep reading floats.
// Then (issue 23, a fifth pass, the VBMI kernel's own work): 64 levels in one half of a table
// read it with half the permutes and no blends, and its channel loop is unrolled (no indexed
// stack array of values). One thread's CPU time, 8-bit, medians of 8 interleaved runs at load
// 1.4-2.9: ramp 2.10 -> 1.36 ms, Memorial 512x768 1.05 -> 0.76 ms; 2 threads against the 8-bit
// floor 4.6x -> 3.2x (runs 2.6-4.4x), so the 3x aim is still not met (docs/hdr.md).
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

// The level of N code values, as the scalar loop's level_of: int(min(s, top)) with s = z scale
// + 0.5, and 0 where s is not above 0 (NaN too).
template <class DF, class DI>
HWY_INLINE hn::Vec<DI> LevelOf(DF df, DI di, hn::Vec<DF> z, hn::Vec<DF> scale, hn::Vec<DF> half, hn::Vec<DF> top) {
  hn::Vec<DF> s = hn::Add(hn::Mul(z, scale), half);
#if HWY_ARCH_X86 && HWY_TARGET != HWY_SCALAR && HWY_TARGET != HWY_EMU128
  // x86's max returns its second operand when either is NaN: max(s, 0) is 0 for NaN and for
  // s <= 0, in one instruction instead of a compare and a select.
  s = hn::Max(s, hn::Zero(df));
#else
  s = hn::IfThenElseZero(hn::Gt(s, hn::Zero(df)), s);
#endif
  s = hn::Min(s, top);
  // s is in [0, top] here, so the conversion cannot overflow. Highway 1.0.3's ConvertTo still
  // pays four more instructions per vector to fix an overflow up on x86; the bare truncating
  // conversion of each x86 target does not (merge 3x1280x960 on one thread: see the head).
#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
  return hn::Vec<DI>{_mm512_cvttps_epi32(s.raw)};
#elif HWY_TARGET == HWY_AVX2
  return hn::Vec<DI>{_mm256_cvttps_epi32(s.raw)};
#elif HWY_TARGET == HWY_SSE4 || HWY_TARGET == HWY_SSSE3
  return hn::Vec<DI>{_mm_cvttps_epi32(s.raw)};
#else
  return hn::ConvertTo(di, s);
#endif
}

// The running sums of one vector of N channels over the frames: sw = sum of w[index] s_k and
// swx = sum of wx[index] s_k / t_k, added frame after frame from +0.
#if HWY_TARGET == HWY_SCALAR
template <class DF>
struct FrameSums {
  using VF = hn::Vec<DF>;
  VF sw, swx;
  explicit FrameSums(DF df) : sw(hn::Zero(df)), swx(hn::Zero(df)) {}
  static VF Pair(DF, VF fw, VF) { return fw; }  // unused: nothing to pair
  template <class VI>
  HWY_INLINE void Add(DF df, const MergeRowInput& in, VI index, VF fw, VF fx, VF /*fwx*/) {
    sw = hn::Add(sw, hn::Mul(hn::GatherIndex(df, in.w, index), fw));  // one lane: nothing to pair
    swx = hn::Add(swx, hn::Mul(hn::GatherIndex(df, in.wx, index), fx));
  }
  HWY_INLINE void Finish(DF, VF& w_sum, VF& wx_sum) const { w_sum = sw, wx_sum = swx; }
};
#else
// table[index] of 64-bit entries for 32-bit indices. x86 gathers them by 32-bit indices
// directly; Highway 1.0.3 only gathers 64-bit entries by 64-bit indices, which costs two
// widenings and an extract per vector of indices on top of the gathers.
template <class DU64, class VI32>
HWY_INLINE hn::Vec<DU64> Gather64(DU64 du64, const uint64_t* table, VI32 index) {
#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
  (void)du64;
  return hn::Vec<DU64>{_mm512_i32gather_epi64(index.raw, table, 8)};
#elif HWY_TARGET == HWY_AVX2
  (void)du64;
  return hn::Vec<DU64>{_mm256_i32gather_epi64(reinterpret_cast<const long long*>(table), index.raw, 8)};
#else
  return hn::GatherIndex(du64, table, hn::PromoteTo(hn::RebindToSigned<DU64>(), index));
#endif
}

// One 64-bit read per lane fetches w and wx together (w_wx): half the reads of two tables
// (AVX-512 on one thread: 20.1 -> 9.6 ms of the merge, see the head). The pairs stay paired
// in the sums (lanes 2i, 2i + 1 of `lower` hold w and wx of channel i, times s_k and s_k / t_k),
// so they are split into sw and swx once per group instead of once per frame: each sum is
// still the same products added in the same order.
template <class DF>
struct FrameSums {
  using VF = hn::Vec<DF>;
  VF lower, upper;  // pairs of channels 0 .. N/2 - 1 and N/2 .. N - 1
  explicit FrameSums(DF df) : lower(hn::Zero(df)), upper(hn::Zero(df)) {}
  // (s_k, s_k / t_k) in every pair of lanes: the factors of a paired (w, wx) read.
  static VF Pair(DF df, VF fw, VF fx) { return hn::InterleaveLower(df, fw, fx); }
  template <class VI>
  HWY_INLINE void Add(DF df, const MergeRowInput& in, VI index, VF /*fw*/, VF /*fx*/, VF fwx) {
    const hn::Repartition<uint64_t, DF> du64;  // half as many lanes
    const hn::Half<hn::RebindToSigned<DF>> dhalf;
    const auto lo = hn::BitCast(df, Gather64(du64, in.w_wx, hn::LowerHalf(dhalf, index)));
    const auto hi = hn::BitCast(df, Gather64(du64, in.w_wx, hn::UpperHalf(dhalf, index)));
    lower = hn::Add(lower, hn::Mul(lo, fwx));
    upper = hn::Add(upper, hn::Mul(hi, fwx));
  }
  HWY_INLINE void Finish(DF df, VF& w_sum, VF& wx_sum) const {
    w_sum = hn::ConcatEven(df, upper, lower);
    wx_sum = hn::ConcatOdd(df, upper, lower);
  }
};
#endif

// kCodes: the levels are in.codes' bytes (256 levels), else computed from in.rows' floats.
template <bool kCodes>
HWY_NOINLINE MergeRowResult MergeRowOf(const MergeRowInput& in, float* out, uint8_t* flags, uint32_t* redo) {
  const hn::ScalableTag<float> df;
  const hn::RebindToSigned<decltype(df)> di;
  const hn::Rebind<uint8_t, decltype(di)> du8;  // N bytes
  using VF = hn::Vec<decltype(df)>;
  using VI = hn::Vec<decltype(di)>;
  const size_t N = hn::Lanes(df);
  // A group of N pixels is 3 vectors of N interleaved codes; lane j of vector v holds channel
  // (v N + j) mod 3, whose table starts at that channel times `levels`.
  HWY_ALIGN int32_t channel_offset[3 * hn::MaxLanes(df)];
  for (size_t i = 0; i < 3 * N; ++i) channel_offset[i] = int32_t(i % 3) * in.levels;
  VI offset[3];
  for (size_t v = 0; v < 3; ++v) offset[v] = hn::Load(di, channel_offset + v * N);
  // The bounds of a black pixel at level 0 in the longest frame and of a clipped one at the top
  // level in the shortest, per lane of each vector: what a flat black or clipped region takes
  // without a gather (the gathers of those bounds were a sixth of the benchmark's merge).
  HWY_ALIGN float bound_lane[3 * hn::MaxLanes(df)];
  VF long_at_zero[3], short_at_top[3];
  for (size_t i = 0; i < 3 * N; ++i) bound_lane[i] = in.bound_long[channel_offset[i]];
  for (size_t v = 0; v < 3; ++v) long_at_zero[v] = hn::Load(df, bound_lane + v * N);
  for (size_t i = 0; i < 3 * N; ++i) bound_lane[i] = in.bound_short[channel_offset[i] + in.levels - 1];
  for (size_t v = 0; v < 3; ++v) short_at_top[v] = hn::Load(df, bound_lane + v * N);
  const VI top_level = hn::Set(di, in.levels - 1);
  const VF scale = hn::Set(df, float(in.levels - 1));  // code -> level, before + 0.5
  const VF half = hn::Set(df, 0.5f);
  const VF top = hn::Set(df, float(in.levels - 1));
  const VF zero = hn::Zero(df);
  const VI zero_through = hn::Set(di, in.zero_through), zero_from = hn::Set(di, in.zero_from);
  const VI below_sat = hn::Set(di, in.sat_level - 1);
  const VI above_black = hn::Set(di, in.black_level + 1);
  // The levels of frame k's N channel codes from code `at` of the row on.
  auto levels_at = [&](size_t k, size_t at) HWY_ATTR -> VI {
    if constexpr (kCodes)
      return hn::PromoteTo(di, hn::LoadU(du8, in.codes[k] + at));
    else
      return LevelOf(df, di, hn::LoadU(df, in.rows[k] + at), scale, half, top);
  };
  // Per lane of a group with a channel no frame weighs: 1 saturated, 2 black, 4 neither.
  constexpr int32_t kMixed = 4;
  static_assert(kSaturatedEverywhere == 1 && kBlackEverywhere == 2, "lane codes are the flag bits");
  HWY_ALIGN int32_t lane_code[3 * hn::MaxLanes(df)];
  const size_t groups = in.width / N;
  MergeRowResult result;
  size_t first_group = 0;
#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
  // 256 levels on a CPU with VBMI: table reads as byte permutes (merge_kernel_vbmi.cpp) for
  // the row's blocks of 64 pixels, the gathers below for the rest.
  if (merge_vbmi_usable(in)) {
    result = merge_row_vbmi(in, out, flags, redo);
    first_group = result.done / N;
  }
#endif
  for (size_t g = first_group; g < groups; ++g) {
    const size_t first_float = 3 * N * g;
    FrameSums<decltype(df)> sums[3] = {FrameSums<decltype(df)>(df), FrameSums<decltype(df)>(df),
                                       FrameSums<decltype(df)>(df)};
    for (size_t k = 0; k < in.frames; ++k) {
      const VF fw = hn::Set(df, in.frame_w[k]);
      const VF fx = hn::Set(df, in.frame_wx[k]);
      const VF fwx = FrameSums<decltype(df)>::Pair(df, fw, fx);
      for (size_t v = 0; v < 3; ++v) {
        const VI level = levels_at(k, first_float + v * N);
        // Every lane black or clipped in this frame: it adds +0 to both sums, so skip the reads.
        if (hn::AllFalse(di, hn::And(hn::Gt(level, zero_through), hn::Lt(level, zero_from)))) continue;
        sums[v].Add(df, in, hn::Add(level, offset[v]), fw, fx, fwx);
      }
    }
    bool all_weighted = true;
    VF value[3], sw[3];
    for (size_t v = 0; v < 3; ++v) {
      VF swx;
      sums[v].Finish(df, sw[v], swx);
      value[v] = hn::Div(swx, sw[v]);
      all_weighted = all_weighted && hn::AllTrue(df, hn::Gt(sw[v], zero));
    }
    if (HWY_UNLIKELY(!all_weighted)) {  // a channel clipped or black in every frame
      for (size_t v = 0; v < 3; ++v) {
        // The levels over the frames, and the table indices in the shortest and the longest
        // frame, computed again here: the common path does without them.
        VI lowest = hn::Set(di, in.levels), highest = hn::Set(di, -1);
        VI at_shortest = hn::Zero(di), at_longest = hn::Zero(di);
        for (size_t k = 0; k < in.frames; ++k) {
          const VI level = levels_at(k, first_float + v * N);
          lowest = hn::Min(lowest, level);
          highest = hn::Max(highest, level);
          if (k == in.shortest) at_shortest = hn::Add(level, offset[v]);
          if (k == in.longest) at_longest = hn::Add(level, offset[v]);
        }
        const auto none = hn::Not(hn::Gt(sw[v], zero));
        const auto sat = hn::Gt(lowest, below_sat);
        const auto black = hn::Lt(highest, above_black);
        // Unweighted lanes saturated everywhere take the shortest frame's bound, the others the
        // longest's; each table is read only when some lane takes it (in a clipped or black
        // region, one of the two).
        const auto sat_f = hn::RebindMask(df, sat);
        const auto take_short = hn::And(none, sat_f);
        const auto take_long = hn::AndNot(sat_f, none);
        if (!hn::AllFalse(df, take_short)) {
          const auto off_top = hn::RebindMask(df, hn::Ne(at_shortest, hn::Add(offset[v], top_level)));
          const VF bound = hn::AllFalse(df, hn::And(take_short, off_top))
                               ? short_at_top[v]
                               : hn::GatherIndex(df, in.bound_short, at_shortest);
          value[v] = hn::IfThenElse(take_short, bound, value[v]);
        }
        if (!hn::AllFalse(df, take_long)) {
          const auto off_zero = hn::RebindMask(df, hn::Ne(at_longest, offset[v]));
          const VF bound = hn::AllFalse(df, hn::And(take_long, off_zero)) ? long_at_zero[v]
                                                                           : hn::GatherIndex(df, in.bound_long, at_longest);
          value[v] = hn::IfThenElse(take_long, bound, value[v]);
        }
        const VI code = hn::IfThenElse(sat, hn::Set(di, 1), hn::IfThenElse(black, hn::Set(di, 2), hn::Set(di, kMixed)));
        hn::Store(hn::IfThenElseZero(hn::RebindMask(di, none), code), di, lane_code + v * N);
      }
      // Pixel p's code is the OR of its three channels' (lanes 3p .. 3p + 2).
      VI c0, c1, c2;
      hn::LoadInterleaved3(di, lane_code, c0, c1, c2);
      const VI pixel_code = hn::Or(hn::Or(c0, c1), c2);
      if (!flags && hn::AllFalse(di, hn::TestBit(pixel_code, hn::Set(di, kMixed)))) {
        // Nothing for the caller's loop and no flag image: only the counts.
        result.saturated += hn::CountTrue(di, hn::TestBit(pixel_code, hn::Set(di, kSaturatedEverywhere)));
        result.black += hn::CountTrue(di, hn::TestBit(pixel_code, hn::Set(di, kBlackEverywhere)));
        result.flagged += hn::CountTrue(di, hn::Ne(pixel_code, hn::Zero(di)));
      } else {
        for (size_t p = 0; p < N; ++p) {
          const int32_t c = hn::ExtractLane(pixel_code, p);
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
    }
    for (size_t v = 0; v < 3; ++v) hn::StoreU(value[v], df, out + first_float + v * N);
  }
  result.done = groups * N;
  return result;
}

MergeRowResult MergeRow(const MergeRowInput& in, float* out, uint8_t* flags, uint32_t* redo) {
  return in.codes ? MergeRowOf<true>(in, out, flags, redo) : MergeRowOf<false>(in, out, flags, redo);
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
