// The merge's row kernel for 256-level tables on CPUs with AVX-512 VBMI (merge_kernel.h,
// merge_row_vbmi): the table reads as byte permutes of registers instead of gathers.
//
// Why: the Highway kernel (merge_kernel.cpp) spends most of its time on the 64-bit gathers of
// (w, wx), one per channel code and frame, and on gathers of the bounds of unweighted
// channels. A 256-entry float table is 4 byte planes of 256 bytes (byte p of every entry);
// vpermi2b looks 64 byte indices up in 128 bytes at once, so one plane of 64 codes is two
// permutes and a select on the index's top bit, and 4 planes are put back together as 4
// vectors of 16 floats by 8 unpacks: 64 table reads in ~20 register operations.
//
// The tables are per channel, so the codes are first split into channel planes: a block of
// 64 pixels is 192 interleaved codes per frame, turned into levels (the scalar loop's
// level_of), packed to bytes and permuted into one vector of 64 levels per channel. Their
// byte order is chosen so that the unpacks give pixels in order (pi below); the sums, the
// division and the bounds are then per channel and pixel, and the three channels are
// interleaved again for the store. With 8-bit codes (MergeRowInput::codes, an 8-bit bracket)
// the 192 codes of a block are loaded as 3 vectors of bytes, already levels, and split into
// channel planes by another pair of permute indices (the codes' own byte order): no float
// loads, no conversion, a quarter of the bytes (what that gained and where the time goes
// then: merge_kernel.cpp's head comment, docs/hdr.md).
//
// Most of the work is then the table reads' shuffles (per read of 64 levels: 8 permutes, 4
// blends, 8 unpacks). 64 levels all in one half of a table, [0, 128) or [128, 256) (one
// channel of a 64-pixel run of a frame, dark or bright: common in real scenes, where a frame's
// runs are rarely spread over the whole code range), take one permute per plane and no blend:
// a branch on the index's top bits, taken for the sums' two tables together and for a bound's.
//
// Bit-identical to the scalar loop as the Highway kernel is: the same level, sums from +0 of
// table[level] * factor frame after frame (a frame whose 64 levels of a channel all have
// w = wx = 0 is skipped: it adds +0), one IEEE division; no FMA (-ffp-contract=off, and the
// products and sums are separate intrinsics). Only this file is compiled for AVX-512 VBMI
// (the pragma below, after every include, so no inline function of a header gets AVX-512
// code); merge_kernel.cpp's AVX-512 target calls it when the CPU has VBMI.
#include <cstddef>
#include <cstdint>
#include <type_traits>

#include "hdr/merge.h"
#include "hdr/merge_kernel.h"

#if !defined(__x86_64__)
namespace lp::detail {  // not x86-64: never usable, never called
void set_merge_vbmi_for_test(bool) {}
bool merge_vbmi_supported() { return false; }
bool merge_vbmi_usable(const MergeRowInput&) { return false; }
MergeRowResult merge_row_vbmi(const MergeRowInput&, float*, uint8_t*, uint32_t*) { return {}; }
}  // namespace lp::detail
#else
#include <immintrin.h>

namespace lp::detail {
namespace {

bool g_vbmi_allowed = true;  // set_merge_vbmi_for_test

// Byte position j of a channel plane holds pixel pi(j) of the block: j = 16 i + 4 q + r holds
// pixel 16 q + 4 i + r (so the unpacks of the lookup give vector q = pixels 16 q .. 16 q + 15).
// pi is its own inverse.
constexpr int pi(int j) { return 16 * ((j / 4) % 4) + 4 * (j / 16) + j % 4; }

// Where code f (0 .. 191, interleaved RGB of the block) lands in the three byte vectors the
// packs make of one frame's 12 vectors of levels: vector g = f / 64; in it, packs of 4 level
// vectors (packus 32 -> 16 -> 8 bits, per 128-bit lane) put element 4 i + r of level vector
// m' at byte 16 i + 4 m' + r.
constexpr int packed_at(int f) {
  const int g = f / 64, e = f % 64, m = e / 16, i = (e % 16) / 4, r = e % 4;
  return 64 * g + 16 * i + 4 * m + r;
}

struct Indices {
  // Channel plane c from the packed vectors: permutex2var of the first two (a 7-bit index
  // into 128 bytes), then the bytes from the third where `from_third` (a 6-bit index).
  alignas(64) uint8_t first_two[3][64] = {};
  alignas(64) uint8_t third[3][64] = {};
  uint64_t from_third[3] = {};
  // The same for 8-bit codes (MergeRowInput::codes), loaded as they are: code f at byte f.
  alignas(64) uint8_t codes_first_two[3][64] = {};
  alignas(64) uint8_t codes_third[3][64] = {};
  uint64_t codes_from_third[3] = {};
  alignas(64) uint8_t to_pixel_order[64] = {};  // permutexvar: a plane in pixel order
  // Output vector u of 16 pixels' interleaved RGB from the three channels' vectors of them:
  // permutex2var of R and G (a 5-bit index), then B where `from_blue`.
  alignas(64) uint32_t red_green[3][16] = {};
  alignas(64) uint32_t blue[3][16] = {};
  uint16_t from_blue[3] = {};
  constexpr Indices() {
    for (int c = 0; c < 3; ++c)
      for (int j = 0; j < 64; ++j) {
        const int s = packed_at(3 * pi(j) + c);
        if (s < 128) {
          first_two[c][j] = uint8_t(s);
        } else {
          third[c][j] = uint8_t(s - 128);
          from_third[c] |= uint64_t(1) << j;
        }
        const int f = 3 * pi(j) + c;
        if (f < 128) {
          codes_first_two[c][j] = uint8_t(f);
        } else {
          codes_third[c][j] = uint8_t(f - 128);
          codes_from_third[c] |= uint64_t(1) << j;
        }
      }
    for (int j = 0; j < 64; ++j) to_pixel_order[j] = uint8_t(pi(j));
    for (int u = 0; u < 3; ++u)
      for (int t = 0; t < 16; ++t) {
        const int f = 16 * u + t, pixel = f / 3, c = f % 3;
        if (c == 2) {
          blue[u][t] = uint32_t(pixel);
          from_blue[u] = uint16_t(from_blue[u] | (1u << t));
        } else {
          red_green[u][t] = uint32_t(16 * c + pixel);
        }
      }
  }
};
constexpr Indices kIdx;

constexpr size_t kPlaneBytes = 4 * 256;  // one table of one channel
constexpr size_t kPrefetchFloats = 2 * 192;  // two blocks ahead (of floats or codes)

}  // namespace

void set_merge_vbmi_for_test(bool allowed) { g_vbmi_allowed = allowed; }

bool merge_vbmi_supported() {
  // libgcc's checks include the OS's support of the AVX-512 state (XCR0).
  static const bool cpu = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
                          __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512vl") &&
                          __builtin_cpu_supports("avx512vbmi") && __builtin_cpu_supports("popcnt") &&
                          __builtin_cpu_supports("bmi") && __builtin_cpu_supports("bmi2");
  return cpu;
}

bool merge_vbmi_usable(const MergeRowInput& in) {
  return merge_vbmi_supported() && g_vbmi_allowed && in.planes && in.levels == 256 && in.frames <= kMergeVbmiMaxFrames && in.width >= 64;
}

}  // namespace lp::detail

#if defined(__clang__)  // clang has no GCC target pragma (the sanitizer and fuzzer builds)
#pragma clang attribute push(__attribute__((target("avx512f,avx512bw,avx512dq,avx512vl,avx512vbmi,popcnt,bmi,bmi2"))), \
                             apply_to = function)
#else
// GCC 12's intrinsics start some results from _mm512_undefined_*(), which -Wmaybe-uninitialized
// takes for a read of an uninitialised value (Highway silences it the same way).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC push_options
#pragma GCC target("avx512f,avx512bw,avx512dq,avx512vl,avx512vbmi,popcnt,bmi,bmi2")
#endif

namespace lp::detail {
namespace {

// Which halves of a 256-entry table the 64 levels of a lookup fall in.
enum class Halves { kLow, kHigh, kBoth };

// 64 entries of one channel's 256-entry float table (4 byte planes at `planes`) at the levels
// `index` (in pi order, `high`: levels >= 128), as 4 vectors of 16 floats in pixel order.
// kHalves other than kBoth: every level is in that half (high is 0 or all ones), so one
// permute per plane reads it and there is nothing to blend.
template <Halves kHalves = Halves::kBoth>
inline void lookup(const uint8_t* planes, __m512i index, __mmask64 high, __m512 value[4]) {
  __m512i b[4];
  for (int p = 0; p < 4; ++p) {
    const uint8_t* t = planes + 256 * p;
    if constexpr (kHalves == Halves::kLow) {
      b[p] = _mm512_permutex2var_epi8(_mm512_loadu_si512(t), index, _mm512_loadu_si512(t + 64));
    } else if constexpr (kHalves == Halves::kHigh) {
      b[p] = _mm512_permutex2var_epi8(_mm512_loadu_si512(t + 128), index, _mm512_loadu_si512(t + 192));
    } else {
      const __m512i lo = _mm512_permutex2var_epi8(_mm512_loadu_si512(t), index, _mm512_loadu_si512(t + 64));
      const __m512i hi = _mm512_permutex2var_epi8(_mm512_loadu_si512(t + 128), index, _mm512_loadu_si512(t + 192));
      b[p] = _mm512_mask_blend_epi8(high, lo, hi);
    }
  }
  // Little-endian floats from their bytes; per 128-bit lane i, bytes 16 i + 4 q .. + 3 end up
  // in vector q (pi put pixels 16 q + 4 i .. there).
  const __m512i lo01 = _mm512_unpacklo_epi8(b[0], b[1]), hi01 = _mm512_unpackhi_epi8(b[0], b[1]);
  const __m512i lo23 = _mm512_unpacklo_epi8(b[2], b[3]), hi23 = _mm512_unpackhi_epi8(b[2], b[3]);
  value[0] = _mm512_castsi512_ps(_mm512_unpacklo_epi16(lo01, lo23));
  value[1] = _mm512_castsi512_ps(_mm512_unpackhi_epi16(lo01, lo23));
  value[2] = _mm512_castsi512_ps(_mm512_unpacklo_epi16(hi01, hi23));
  value[3] = _mm512_castsi512_ps(_mm512_unpackhi_epi16(hi01, hi23));
}

// lookup() of levels that may fall in one half of the table, as the sums' lookups below.
inline void lookup_by_halves(const uint8_t* planes, __m512i index, __m512 value[4]) {
  const __mmask64 high = _mm512_movepi8_mask(index);
  if (high == 0) {
    lookup<Halves::kLow>(planes, index, high, value);
  } else if (high == ~__mmask64(0)) {
    lookup<Halves::kHigh>(planes, index, high, value);
  } else {
    lookup(planes, index, high, value);
  }
}

// Levels >= `from` (a level in int, clamped to what a byte can say).
inline __mmask64 at_or_above(__m512i level, int from) {
  if (from <= 0) return ~__mmask64(0);
  if (from > 255) return 0;
  return _mm512_cmpge_epu8_mask(level, _mm512_set1_epi8(char(from)));
}

inline __mmask16 part(__mmask64 m, int q) { return __mmask16(m >> (16 * q)); }

// One block of 64 pixels of 8-bit codes whose three channels share their tables
// (MergeRowInput::one_table: the linear default, sRGB): the 192 interleaved codes are read as
// 3 vectors of 64 levels, with no split into channel planes, and their sums come out
// interleaved, so the output needs no interleave either (per block 18 + 24 shuffles fewer, 9
// more). Lane i of vector g is the block's code 64 g + i, whatever its channel: the same table
// reads, products, sums in frame order (a frame whose 64 lanes all weigh 0 adds +0, as
// there) and division as the channel planes' path, so bit-identical to it. False when some
// lane has no weight in any frame: the caller's path then does the whole block again, with
// the bounds and flags of such channels (it overwrites what was stored here).
inline bool one_table_block(const MergeRowInput& in, size_t first_float, float* out, __m512i to_pixel_order,
                            __m512i first_weighted, __m512i weighted_span, int span) {
  const __m512 zero = _mm512_setzero_ps();
  const uint8_t* w_at = in.planes;  // channel 0's tables are every channel's
  const uint8_t* wx_at = in.planes + 3 * kPlaneBytes;
  for (int g = 0; g < 3; ++g) {
    __m512 sw[4] = {zero, zero, zero, zero}, swx[4] = {zero, zero, zero, zero};
    for (size_t k = 0; k < in.frames; ++k) {
      const uint8_t* z = in.codes[k] + first_float + 64 * size_t(g);
      _mm_prefetch(reinterpret_cast<const char*>(z + kPrefetchFloats), _MM_HINT_T0);
      const __m512i codes = _mm512_loadu_si512(z);
      if (span < 256 && _mm512_cmplt_epu8_mask(_mm512_sub_epi8(codes, first_weighted), weighted_span) == 0) continue;
      const __m512i index = _mm512_permutexvar_epi8(to_pixel_order, codes);  // byte j: code pi(j), as lookup() reads
      const __mmask64 high = _mm512_movepi8_mask(index);
      const __m512 fw = _mm512_set1_ps(in.frame_w[k]), fx = _mm512_set1_ps(in.frame_wx[k]);
      auto add = [&](auto halves) {
        __m512 t[4];
        lookup<halves.value>(w_at, index, high, t);
        for (int q = 0; q < 4; ++q) sw[q] = _mm512_add_ps(sw[q], _mm512_mul_ps(t[q], fw));
        lookup<halves.value>(wx_at, index, high, t);
        for (int q = 0; q < 4; ++q) swx[q] = _mm512_add_ps(swx[q], _mm512_mul_ps(t[q], fx));
      };
      if (high == 0) {
        add(std::integral_constant<Halves, Halves::kLow>{});
      } else if (high == ~__mmask64(0)) {
        add(std::integral_constant<Halves, Halves::kHigh>{});
      } else {
        add(std::integral_constant<Halves, Halves::kBoth>{});
      }
    }
    for (int q = 0; q < 4; ++q) {
      if (_mm512_cmp_ps_mask(sw[q], zero, _CMP_GT_OQ) != 0xFFFF) return false;
      _mm512_storeu_ps(out + 64 * g + 16 * q, _mm512_div_ps(swx[q], sw[q]));
    }
  }
  return true;
}

// kCodes: the levels are in.codes' bytes, else computed from in.rows' floats.
template <bool kCodes>
MergeRowResult vbmi_row(const MergeRowInput& in, float* out, uint8_t* flags, uint32_t* redo) {
  const __m512 scale = _mm512_set1_ps(float(in.levels - 1)), half = _mm512_set1_ps(0.5f);
  const __m512 top = _mm512_set1_ps(float(in.levels - 1)), zero = _mm512_setzero_ps();
  // Levels in [zero_through + 1, zero_from) have weight: (level - first) mod 256 < span.
  const int span = in.zero_from - in.zero_through - 1;
  const __m512i first_weighted = _mm512_set1_epi8(char(in.zero_through + 1));
  const __m512i weighted_span = _mm512_set1_epi8(char(span));
  __m512i first_two[3], third[3];
  __mmask64 from_third[3];
  for (int c = 0; c < 3; ++c) {
    first_two[c] = _mm512_load_si512(kCodes ? kIdx.codes_first_two[c] : kIdx.first_two[c]);
    third[c] = _mm512_load_si512(kCodes ? kIdx.codes_third[c] : kIdx.third[c]);
    from_third[c] = kCodes ? kIdx.codes_from_third[c] : kIdx.from_third[c];
  }
  const __m512i to_pixel_order = _mm512_load_si512(kIdx.to_pixel_order);
  const uint8_t* w_planes = in.planes;
  const uint8_t* wx_planes = in.planes + 3 * kPlaneBytes;
  const uint8_t* short_planes = in.planes + 6 * kPlaneBytes;
  const uint8_t* long_planes = in.planes + 9 * kPlaneBytes;
  const __m512i level_top = _mm512_set1_epi8(char(255)), level_zero = _mm512_setzero_si512();
  MergeRowResult result;
  const size_t blocks = in.width / 64;
  for (size_t blk = 0; blk < blocks; ++blk) {
    const size_t first_float = 192 * blk;
    if constexpr (kCodes) {
      if (in.one_table &&
          one_table_block(in, first_float, out + first_float, to_pixel_order, first_weighted, weighted_span, span))
        continue;
    }
    // The levels of every frame, one plane per channel (pi order), and which of them have
    // some weighted level (bit 3 k + c).
    __m512i level[kMergeVbmiMaxFrames][3];
    uint64_t weighted_plane = 0;
    for (size_t k = 0; k < in.frames; ++k) {
      __m512i packed[3];
      if constexpr (kCodes) {  // the 192 codes as they are: 3 lines, loaded and prefetched as the floats below
        const uint8_t* z = in.codes[k] + first_float;
        for (int line = 0; line < 3; ++line) _mm_prefetch(reinterpret_cast<const char*>(z + kPrefetchFloats + 64 * line), _MM_HINT_T0);
        for (int g = 0; g < 3; ++g) packed[g] = _mm512_loadu_si512(z + 64 * g);
      } else {
        const float* z = in.rows[k] + first_float;
        // The next blocks' codes: each block's arithmetic is longer than the out-of-order window,
        // so without a hint its loads start only when the block before is done.
        for (int line = 0; line < 12; ++line) _mm_prefetch(reinterpret_cast<const char*>(z + kPrefetchFloats + 16 * line), _MM_HINT_T0);
        for (int g = 0; g < 3; ++g) {
          __m512i l[4];
          for (int m = 0; m < 4; ++m) {
            // The scalar loop's level_of without its max(s, 0): min returns its second operand
            // when either is NaN, so s = NaN stays NaN; the conversion makes NaN and every s <= -1
            // INT_MIN and s in (-1, 0] 0, and the packs below saturate negative levels to 0.
            const __m512 s = _mm512_add_ps(_mm512_mul_ps(_mm512_loadu_ps(z + 64 * g + 16 * m), scale), half);
            l[m] = _mm512_cvttps_epi32(_mm512_min_ps(top, s));  // in [INT_MIN, 255]
          }
          packed[g] = _mm512_packus_epi16(_mm512_packus_epi32(l[0], l[1]), _mm512_packus_epi32(l[2], l[3]));
        }
      }
      for (int c = 0; c < 3; ++c) {
        const __m512i two = _mm512_permutex2var_epi8(packed[0], first_two[c], packed[1]);
        level[k][c] = _mm512_mask_permutexvar_epi8(two, from_third[c], third[c], packed[2]);
        const bool some = span >= 256 ||
                          _mm512_cmplt_epu8_mask(_mm512_sub_epi8(level[k][c], first_weighted), weighted_span) != 0;
        weighted_plane |= uint64_t(some) << (3 * k + size_t(c));
      }
    }
    __m512 value[3][4];
    uint64_t saturated = 0, black = 0, mixed = 0;  // per pixel: a channel of zero weight, and which
    // Unrolled: with c a constant the values' array is registers and constant stack slots, not
    // an indexed array written and read back for the interleave below (docs/hdr.md).
#pragma GCC unroll 3
    for (int c = 0; c < 3; ++c) {
      __m512 sw[4] = {zero, zero, zero, zero}, swx[4] = {zero, zero, zero, zero};
      for (size_t k = 0; k < in.frames; ++k) {
        if (!((weighted_plane >> (3 * k + size_t(c))) & 1)) continue;  // adds +0 to every sum
        const __m512i index = level[k][c];
        const __mmask64 high = _mm512_movepi8_mask(index);
        const __m512 fw = _mm512_set1_ps(in.frame_w[k]), fx = _mm512_set1_ps(in.frame_wx[k]);
        const uint8_t* w_at = w_planes + size_t(c) * kPlaneBytes;
        const uint8_t* wx_at = wx_planes + size_t(c) * kPlaneBytes;
        auto add = [&](auto halves) {
          __m512 t[4];
          lookup<halves.value>(w_at, index, high, t);
          for (int q = 0; q < 4; ++q) sw[q] = _mm512_add_ps(sw[q], _mm512_mul_ps(t[q], fw));
          lookup<halves.value>(wx_at, index, high, t);
          for (int q = 0; q < 4; ++q) swx[q] = _mm512_add_ps(swx[q], _mm512_mul_ps(t[q], fx));
        };
        // 64 levels in one half of the table (a dark or a bright stretch of a frame) take half
        // the permutes and no blends.
        if (high == 0) {
          add(std::integral_constant<Halves, Halves::kLow>{});
        } else if (high == ~__mmask64(0)) {
          add(std::integral_constant<Halves, Halves::kHigh>{});
        } else {
          add(std::integral_constant<Halves, Halves::kBoth>{});
        }
      }
      uint64_t weighed = 0;
      for (int q = 0; q < 4; ++q) {
        value[c][q] = _mm512_div_ps(swx[q], sw[q]);
        weighed |= uint64_t(_mm512_cmp_ps_mask(sw[q], zero, _CMP_GT_OQ)) << (16 * q);
      }
      const uint64_t none = ~weighed;
      if (__builtin_expect(none == 0, 1)) continue;
      // A channel no frame weighs (in pixel order from here): clipped in every frame takes
      // the shortest frame's bound, the others the longest's, as the Highway kernel.
      __m512i lowest = level[0][c], highest = level[0][c];
      for (size_t k = 1; k < in.frames; ++k) {
        lowest = _mm512_min_epu8(lowest, level[k][c]);
        highest = _mm512_max_epu8(highest, level[k][c]);
      }
      const uint64_t sat = at_or_above(_mm512_permutexvar_epi8(to_pixel_order, lowest), in.sat_level);
      const uint64_t blk_black = ~at_or_above(_mm512_permutexvar_epi8(to_pixel_order, highest), in.black_level + 1);
      const uint64_t take_short = none & sat, take_long = none & ~sat;
      if (take_short) {
        const __m512i at = level[in.shortest][c];
        __m512 bound[4];
        if (take_short & _mm512_cmpneq_epi8_mask(_mm512_permutexvar_epi8(to_pixel_order, at), level_top)) {
          lookup_by_halves(short_planes + size_t(c) * kPlaneBytes, at, bound);
        } else {  // all at the top level: no lookup
          for (__m512& b : bound) b = _mm512_set1_ps(in.bound_short[size_t(c) * 256 + 255]);
        }
        for (int q = 0; q < 4; ++q) value[c][q] = _mm512_mask_blend_ps(part(take_short, q), value[c][q], bound[q]);
      }
      if (take_long) {
        const __m512i at = level[in.longest][c];
        __m512 bound[4];
        if (take_long & _mm512_cmpneq_epi8_mask(_mm512_permutexvar_epi8(to_pixel_order, at), level_zero)) {
          lookup_by_halves(long_planes + size_t(c) * kPlaneBytes, at, bound);
        } else {  // all at level 0
          for (__m512& b : bound) b = _mm512_set1_ps(in.bound_long[size_t(c) * 256]);
        }
        for (int q = 0; q < 4; ++q) value[c][q] = _mm512_mask_blend_ps(part(take_long, q), value[c][q], bound[q]);
      }
      saturated |= take_short;
      black |= take_long & blk_black;
      mixed |= take_long & ~blk_black;
    }
    // Interleaved RGB again: 16 pixels (vector q of each channel) are 3 output vectors.
    float* o = out + first_float;
    for (int q = 0; q < 4; ++q)
      for (int u = 0; u < 3; ++u) {
        const __m512 rg = _mm512_permutex2var_ps(value[0][q], _mm512_load_si512(kIdx.red_green[u]), value[1][q]);
        const __m512 rgb = _mm512_mask_permutexvar_ps(rg, kIdx.from_blue[u], _mm512_load_si512(kIdx.blue[u]), value[2][q]);
        _mm512_storeu_ps(o + 48 * q + 16 * u, rgb);
      }
    const uint64_t any = saturated | black | mixed;
    if (__builtin_expect(any == 0, 1)) continue;
    if (!flags && !mixed) {  // nothing for the caller's loop and no flag image: only the counts
      result.saturated += size_t(__builtin_popcountll(saturated));
      result.black += size_t(__builtin_popcountll(black));
      result.flagged += size_t(__builtin_popcountll(any));
      continue;
    }
    for (uint64_t left = any; left; left &= left - 1) {  // pixels in order, as the Highway kernel
      const int x = __builtin_ctzll(left);
      const uint32_t pixel = uint32_t(64 * blk + size_t(x));
      if ((mixed >> x) & 1) {
        redo[result.redone++] = pixel;
        continue;
      }
      const uint8_t code = uint8_t(((saturated >> x) & 1) * kSaturatedEverywhere | ((black >> x) & 1) * kBlackEverywhere);
      result.saturated += code & kSaturatedEverywhere;
      result.black += (code & kBlackEverywhere) >> 1;
      ++result.flagged;
      if (flags) flags[pixel] = code;
    }
  }
  result.done = blocks * 64;
  return result;
}

}  // namespace

MergeRowResult merge_row_vbmi(const MergeRowInput& in, float* out, uint8_t* flags, uint32_t* redo) {
  return in.codes ? vbmi_row<true>(in, out, flags, redo) : vbmi_row<false>(in, out, flags, redo);
}

}  // namespace lp::detail

#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#pragma GCC diagnostic pop
#endif
#endif  // __x86_64__
